// Coarser image levels for large camera images: the pyramid level whose
// pixel count is within a bound, and a valid-pixel mask at that level.
// Level l is the image halved l times (cv::pyrDown and cv::
// buildOpticalFlowPyramid: (w + 1) / 2 by (h + 1) / 2). Used where a
// step needs no more detail than the bound gives: Shi-Tomasi detection in
// the frontend (frontend.detection_max_megapixels) and the loop-closure
// features (loop.feature_max_megapixels).
#pragma once

#include <opencv2/core.hpp>

namespace mcvo {

// The smallest level l in 0..max_level at which width x height / 4^l is at
// most max_megapixels million pixels (max_level when none is); 0 when
// max_megapixels <= 0 (no bound).
int LevelForMegapixels(int width, int height, double max_megapixels, int max_level);

// A CV_8UC1 mask (255 valid) at `levels` halvings: a coarse pixel is valid
// only when each of the 2 x 2 fine pixels it covers is (the last row and
// column repeat where the size is odd).
cv::Mat CoarseMask(const cv::Mat& mask, int levels);

}  // namespace mcvo
