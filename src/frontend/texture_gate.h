// Texture gate of new features (FrontendOptions::texture): a detection is
// kept only where the image as decoded has gradients in two directions over
// the LK window, above the sensor noise.
//
// Why: the detectors run on the tracker's CLAHE'd image, where a blank wall
// (a smooth gradient, 8-bit steps, sensor noise) is stretched up to the clip
// limit and shows corners that are not there. Indoors they took most of the
// feature budget and died within a frame: on the stereo indoor suite
// sequence (st_indoor_s23_expo) 266 of 305 new features died in their first
// frame, with a patch strength (below) of median 0.10 grey levels/px,
// against 1.4 for those that lived; with noise 2 (k360_indoor_s4_noise)
// 0.94 (the noise's own) against 1.6-2.0. Off by default: the features
// that live were the same with it (the textured parts were full at 20 px
// spacing), and over 18 suite runs its ATE was better on 8, worse on 8
// (results/suite_texture_gate.md).
//
// Patch strength: sqrt of the smaller eigenvalue of the structure tensor
// (mean of g g^T, g the Sobel gradient / 8 in grey levels per pixel) over the
// (2 h + 1)^2 window, h = lk.window_px / 2: the condition LK itself needs
// (Shi-Tomasi's "good features to track"), on the decoded image. A patch of
// noise of std sigma alone has ~0.43 sigma (each Sobel / 8 component has std
// sqrt(12) / 8 sigma). cv::cornerMinEigenVal with a window of that size
// gives the same quantity for every pixel of the image; the gate needs it
// at a few hundred candidates, so it sums the window there (OpenCV's Sobel
// gradients, computed once per image).
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace mcvo::internal {

// Noise std (grey levels) of an 8-bit image: median |I * N| / (0.6745 * 6),
// N = [1 -2 1; -2 4 -2; 1 -2 1] (zero on planes; 6 sigma on white noise),
// over every second pixel of every second row where it is not 0 (clipped
// or perfectly flat regions, a saturated sky, carry no noise to measure and
// would pull the median down; white noise gives 0 in a few % of pixels).
// Structure raises it only where it covers more than half the image.
double EstimateNoiseSigma(const cv::Mat& image);

class TextureGate {
 public:
  // image: CV_8UC1 as decoded; half_window: h.
  TextureGate(const cv::Mat& image, int half_window);

  // The patch strength at pixel (nearest pixel; the window clipped to the image).
  double Strength(const Eigen::Vector2f& pixel) const;
  // max(min_gradient, noise_factor x 0.433 x EstimateNoiseSigma(image)).
  double Threshold(double min_gradient, double noise_factor) const;

 private:
  cv::Mat gx_, gy_;  // CV_16S Sobel
  int half_window_ = 7;
  double noise_sigma_ = 0.0;
};

}  // namespace mcvo::internal
