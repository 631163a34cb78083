// Feature selection: which new detections join the tracked features of a
// camera. The paper's 3-priority quad-tree (reference notes, "3-priority
// quad-tree selection"), the plain quad-tree and score baselines, and the
// paper's SFD uniformity metric.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "mcvo/frontend/detector.h"

namespace mcvo {

struct SelectionInput {
  std::vector<Eigen::Vector2f> tracked;  // features kept from the previous frame
  const Detections* candidates = nullptr;
  int image_width = 0;
  int image_height = 0;
  cv::Mat mask;            // CV_8UC1 or empty
  int max_features = 100;  // total wanted: tracked + new
  double min_distance_px = 20.0;
};

// Indices into candidates of the new features, in the order chosen. Never
// more than max(0, max_features - tracked); no new feature within
// min_distance_px of a tracked feature or of another chosen one; none in the
// mask's zero pixels. Deterministic.
std::vector<int> SelectFeatures(const SelectionInput& input, FeatureSelection method);

// SFD (the paper's spatial feature distribution metric): the variance of the
// feature counts over the cells of a uniform grid (grid_cols x grid_rows) over
// the image; lower is more uniform.
double ComputeSfd(const std::vector<Eigen::Vector2f>& pixels, int image_width, int image_height,
                  int grid_cols = 8, int grid_rows = 8);

}  // namespace mcvo
