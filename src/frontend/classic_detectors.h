// Private to the frontend module: the classic detectors behind Detector
// (include/mcvo/frontend/detector.h), built by CreateDetector.
#pragma once

#include <memory>

#include "mcvo/frontend/detector.h"

namespace mcvo {
namespace internal {

// Shi-Tomasi: the minimum eigenvalue of the 3x3 structure tensor
// (cv::cornerMinEigenVal, Sobel aperture 3) is the score; candidates are its
// strict 3x3 local maxima above 1% of the image's maximum response (the
// quality level of cv::goodFeaturesToTrack in VINS), refined to sub-pixel by a
// separable parabola fit through the peak and its neighbours. No minimum
// distance here: spacing is the selection's job (frontend/selection.h), which
// needs every candidate with its score. No descriptors.
std::unique_ptr<Detector> MakeShiTomasiDetector();

// ORB: cv::ORB with the FAST score (keypoint.response is the score), 8 levels
// at scale 1.2, edge threshold and patch 31 px (OpenCV defaults; descriptors
// need that margin), 32-byte rBRIEF descriptors (CV_8U rows) of the returned
// candidates.
std::unique_ptr<Detector> MakeOrbDetector();

}  // namespace internal
}  // namespace mcvo
