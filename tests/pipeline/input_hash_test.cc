// run.json's "dataset_sha256" (HashDatasetContent, pipeline/run.h): what
// `mcvo batch` compares to call a finished run up to date. Every input that
// changes a result must change it; what does not change a result must not.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "mcvo/pipeline/run.h"

namespace mcvo {
namespace {

DatasetIndex SmallIndex() {
  DatasetIndex index;
  index.format = "generic";
  for (int f = 0; f < 5; ++f) {
    DatasetFrame frame;
    frame.t_ns = 100000000LL * f;
    frame.images = {"images/cam0/" + std::to_string(f) + ".png", "images/cam1/" + std::to_string(f) + ".png"};
    index.frames.push_back(frame);
  }
  Trajectory gt;
  gt.has_time = true;
  for (int f = 0; f < 5; ++f) {
    StampedPose pose;
    pose.t_ns = 100000000LL * f;
    pose.world_from_body.translation = Eigen::Vector3d(0.5 * f, 0.01 * f, 0.0);
    gt.poses.push_back(pose);
  }
  index.ground_truth = gt;
  index.masks = {cv::Mat(8, 10, CV_8UC1, cv::Scalar(255)), cv::Mat()};
  return index;
}

TEST(HashDatasetContent, ChangesWithTheGroundTruthTheTimesAndTheMasks) {
  const DatasetIndex base = SmallIndex();
  const std::string hash = HashDatasetContent(base, 5);
  EXPECT_EQ(HashDatasetContent(SmallIndex(), 5), hash);

  DatasetIndex scaled = base;  // groundtruth.tum scaled by 1.1
  for (StampedPose& pose : scaled.ground_truth->poses) pose.world_from_body.translation *= 1.1;
  EXPECT_NE(HashDatasetContent(scaled, 5), hash);

  DatasetIndex nudged = base;  // one coordinate, in its last digit
  nudged.ground_truth->poses[3].world_from_body.translation.x() =
      std::nextafter(nudged.ground_truth->poses[3].world_from_body.translation.x(), 10.0);
  EXPECT_NE(HashDatasetContent(nudged, 5), hash);

  DatasetIndex rotated = base;
  rotated.ground_truth->poses[1].world_from_body.rotation =
      Eigen::Quaterniond(0.999, 0.0447, 0.0, 0.0).normalized();
  EXPECT_NE(HashDatasetContent(rotated, 5), hash);

  DatasetIndex no_gt = base;
  no_gt.ground_truth.reset();
  EXPECT_NE(HashDatasetContent(no_gt, 5), hash);

  DatasetIndex shifted = base;  // frames.csv times moved by 1 ms
  for (DatasetFrame& frame : shifted.frames) frame.t_ns += 1000000;
  EXPECT_NE(HashDatasetContent(shifted, 5), hash);

  DatasetIndex missing = base;  // an image marked missing
  missing.frames[2].images[1].clear();
  EXPECT_NE(HashDatasetContent(missing, 5), hash);

  DatasetIndex masked = base;  // one mask pixel
  masked.masks[0] = base.masks[0].clone();
  masked.masks[0].at<uint8_t>(3, 4) = 0;
  EXPECT_NE(HashDatasetContent(masked, 5), hash);

  DatasetIndex new_mask = base;  // a mask added to the second camera
  new_mask.masks[1] = cv::Mat(8, 10, CV_8UC1, cv::Scalar(255));
  EXPECT_NE(HashDatasetContent(new_mask, 5), hash);
}

TEST(HashDatasetContent, CoversOnlyTheFramesTheRunUses) {
  const DatasetIndex base = SmallIndex();
  DatasetIndex later = base;  // a time after the run's 3 frames
  later.frames[4].t_ns += 1;
  EXPECT_EQ(HashDatasetContent(later, 3), HashDatasetContent(base, 3));
  EXPECT_NE(HashDatasetContent(later, 5), HashDatasetContent(base, 5));
  // Image paths are not content (the image hashes are): a moved dataset is the same.
  DatasetIndex moved = base;
  for (DatasetFrame& frame : moved.frames) {
    for (std::filesystem::path& path : frame.images) path = "/elsewhere" / path;
  }
  EXPECT_EQ(HashDatasetContent(moved, 5), HashDatasetContent(base, 5));
}

}  // namespace
}  // namespace mcvo
