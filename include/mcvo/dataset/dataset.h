// Datasets: every supported layout is opened into one DatasetIndex (rig,
// synchronized frame list, ground truth), then streamed as decoded
// multi-camera frames by FrameStream.
//
//   DatasetOptions options;  options.root = "KITTI-360"; options.format = "kitti360";
//   options.sequence = "2013_05_28_drive_0000_sync";
//   const DatasetIndex index = OpenDataset(options);       // metadata only, validated
//   FrameStream stream(index, {/*threads=*/2, /*prefetch=*/8});
//   while (std::optional<FrameImages> frame = stream.Next()) { ... }
//
// Layouts: "generic" (what `mcvo synth` writes, docs/dataset-format.md),
// "kitti360", "kitti" (KITTI odometry sequences as shipped), "euroc" (ASL),
// "kalibr" (MultiCamData: camchain.yaml + camN/<ns>.png), "rosbag" (a ROS1
// bag with a Kalibr camchain or rig.json; images streamed from the bag).
// Facts and conventions: docs/datasets.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/io/trajectory_io.h"

namespace mcvo {

// What to do with a frame where some camera has no image (or no image
// within the synchronisation tolerance).
enum class MissingImagePolicy {
  kMarkMissing,  // keep the frame; that camera's image is marked missing
  kSkipFrame,    // drop the frame
};

struct DatasetOptions {
  std::filesystem::path root;        // dataset folder (layout-specific meaning)
  std::string format = "auto";       // auto | generic | kitti360 | kitti | euroc | kalibr | rosbag
  std::string sequence;              // kitti360: e.g. 2013_05_28_drive_0000_sync; kitti: e.g. 06
  std::vector<std::string> cameras;  // subset and order of cameras (names); empty: all
  MissingImagePolicy missing_images = MissingImagePolicy::kMarkMissing;
  // Largest time difference between the images of one frame (layouts with
  // per-camera time stamps: kitti360, euroc, kalibr). The published MCVO uses 0.04 s.
  double sync_tolerance_s = 0.04;
  // kitti360 fisheyes without a mask file: pixels whose bearing is at most
  // this far from the optical axis are valid (the lens' image circle).
  double fisheye_max_angle_deg = 95.0;
  // rosbag (root = the .bag file): the calibration, a Kalibr camchain
  // (*.yaml) or a rig.json (*.json), required; the image topic per camera
  // (camera name, topic), default the camchain's `rostopic`, else
  // /<camera>/image_raw; ground truth from a pose topic (PoseStamped,
  // TransformStamped, Odometry) or a trajectory file (TUM, EuRoC CSV, ...),
  // at most one of them, none by default.
  std::filesystem::path calib;
  std::vector<std::pair<std::string, std::string>> topics;
  std::string gt_topic;
  std::filesystem::path gt_file;

  // Throws UsageError naming the bad field.
  void Check() const;
};

struct DatasetFrame {
  int64_t t_ns = 0;                           // frame time (the reference camera's, or the mean for generic)
  std::vector<std::filesystem::path> images;  // one per rig camera; empty path = missing
};

struct DatasetIndex {
  std::string format;  // the layout that was read
  std::string name;    // sequence name, for logs and reports
  std::filesystem::path root;
  Rig rig;                                 // cameras in the order of DatasetOptions::cameras
  std::vector<DatasetFrame> frames;        // strictly increasing t_ns
  std::optional<Trajectory> ground_truth;  // world_from_rig, when the dataset has it
  // Masks per camera (CV_8UC1, 255 = valid), empty Mat = no mask. Loaded
  // from the dataset's mask files or generated (kitti360 fisheyes).
  std::vector<cv::Mat> masks;
  // Human-readable notes about what the reader did: synchronisation results
  // (frames dropped or marked missing, and why), generated masks, ...
  std::vector<std::string> log;
  // Where the rig origin was moved, in the dataset's rig frame, when it was
  // (OpenRunDataset, pipeline/run.h: a one-camera rig's origin moves to the
  // camera centre); the ground truth above is moved with it.
  std::optional<Eigen::Vector3d> origin_moved_to;
  // Layouts whose images lie in one container file (rosbag): keeps the
  // container open and registered while any copy of the index lives, so
  // that the image paths below it decode (mcvo/dataset/image_container.h).
  std::shared_ptr<const void> image_container;
};

// Reads and validates the dataset's metadata (no image is decoded). Bad input
// throws InputError naming the file (and line or key).
DatasetIndex OpenDataset(const DatasetOptions& options);

// Per-layout readers behind OpenDataset (options.format already resolved).
DatasetIndex ReadGenericDataset(const DatasetOptions& options);
DatasetIndex ReadKitti360Dataset(const DatasetOptions& options);
DatasetIndex ReadKittiOdometryDataset(const DatasetOptions& options);
DatasetIndex ReadEurocDataset(const DatasetOptions& options);
DatasetIndex ReadKalibrDataset(const DatasetOptions& options);
DatasetIndex ReadRosbagDataset(const DatasetOptions& options);

// Guesses the layout of a folder: generic (frames.csv + rig.json), kitti360
// (calibration/ + data_2d_raw/), euroc (mav0/ or cam0/data.csv), kitti
// (sequences/, or calib.txt + an image_0 .. image_3 folder), kalibr
// (camchain*.yaml); a file named *.bag: rosbag. Throws InputError when none fits.
std::string DetectDatasetFormat(const std::filesystem::path& root);

// The valid-pixel mask of a camera: 255 where the pixel centre unprojects and
// its bearing is within max_angle_deg of the optical axis (no angle limit
// when max_angle_deg >= 180). Empty Mat when every pixel is valid.
cv::Mat ValidPixelMask(const Camera& camera, double max_angle_deg = 180.0);

// The 8-bit grey image of a decoded image file (a decode with
// cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH), the one every stage uses: an
// 8-bit grey decode as it is (no copy); 16-bit, its high byte (what
// IMREAD_GRAYSCALE gives for a 16-bit PNG); colour (BGR, or BGRA: its colour
// channels), OpenCV's BT.601 grey (cv::cvtColor); any other depth converted
// to 8-bit first (cv::Mat::convertTo). Empty for an empty decode. The
// frontend (FrameStream) and the loop closer take their grey images this way
// from one decode, which also gives the COLMAP colours: a colour file is
// decoded once, not once in colour and once grey.
cv::Mat GreyOfDecodedImage(const cv::Mat& decoded);

struct FrameImages {
  int index = 0;  // position in DatasetIndex::frames
  int64_t t_ns = 0;
  std::vector<cv::Mat> images;  // CV_8UC1 per camera; empty Mat = missing
  // With FrameStreamOptions::keep_decoded: per camera the decode itself
  // (colour or 16-bit as the file is; images[c] is its GreyOfDecodedImage).
  // Empty otherwise.
  std::vector<cv::Mat> decoded;
  // Wall time of decoding these images on the decoding thread, summed over
  // the cameras (timing only: not deterministic).
  double decode_seconds = 0.0;
};

struct FrameStreamOptions {
  int threads = 0;   // decoding threads; 0: hardware concurrency
  int prefetch = 8;  // frames decoded ahead at most (bounded memory)
  // Hand out each image's decode beside its grey image (FrameImages::decoded):
  // for `mcvo run`, whose loop closer describes keyframes and samples their
  // COLMAP colours without decoding them again (pipeline/loop_image_cache.h).
  bool keep_decoded = false;
};

// Decodes the images of a DatasetIndex ahead of use in background threads,
// in bounded memory, and hands frames out in index order, identical at any
// thread count. A corrupt or unreadable image throws InputError naming the
// file from Next() (the stream stops; no partial frame is returned).
class FrameStream {
 public:
  FrameStream(const DatasetIndex& index, const FrameStreamOptions& options);
  ~FrameStream();
  FrameStream(const FrameStream&) = delete;
  FrameStream& operator=(const FrameStream&) = delete;

  // The next frame in order, or nullopt at the end.
  std::optional<FrameImages> Next();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
