// Which cameras of a rig see the same part of the world: the fraction of
// camera a's view that camera b also sees, for points at a given distance.
#pragma once

#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"

namespace mcvo {

// Distance used by `mcvo info` to report view overlap. 10 m is the range of
// most tracked points in street and room-scale scenes: close enough that the
// baseline matters (a side fisheye and a front camera share few points at
// 10 m), far enough that it does not dominate (a stereo pair overlaps almost
// fully).
inline constexpr double kViewOverlapDepthM = 10.0;

// Fraction in [0, 1] of camera a's view that camera b sees: over a regular
// grid of pixel centres of a (kViewOverlapGrid x kViewOverlapGrid, only those
// inside a's valid domain), the point along the pixel's ray at distance
// `depth_m` from a's centre (a distance, not a z depth: fisheyes see beyond
// 90 deg) is moved into b through the extrinsics, and counts when it projects
// inside b's image and valid domain. Masks are not used. Not symmetric.
// Returns 0 when a has no valid pixel. MCVO_CHECKs depth_m > 0.
double ViewOverlap(const Camera& a, const Camera& b, double depth_m);
// As above, also requiring the pixels to be valid in the cameras' masks
// (CV_8UC1 of the camera's size, non-zero = valid; empty Mat = all valid),
// e.g. DatasetIndex::masks. MCVO_CHECKs the mask sizes.
double ViewOverlap(const Camera& a, const Camera& b, double depth_m, const cv::Mat& mask_a,
                   const cv::Mat& mask_b);

inline constexpr int kViewOverlapGrid = 64;

}  // namespace mcvo
