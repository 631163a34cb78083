// ROS1 bags for the tests, written with the real rosbag library
// (rosbag::Bag in write mode) from a generic dataset (what `mcvo synth`
// writes: rig.json, frames.csv, grey PNG images, groundtruth.tum), and the
// Kalibr camchain.yaml of the same rig.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/io/frame_table.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/io/trajectory_io.h"

namespace mcvo::testing {

// How a camera's images go into the bag: "mono8", "mono16", "bgr8", "rgb8"
// (sensor_msgs/Image), "png", "jpeg" (sensor_msgs/CompressedImage).
struct BagSpec {
  std::map<std::string, std::string> encoding;    // camera name -> kind; default mono8
  std::map<std::string, std::string> topic;       // camera name -> topic; default /<camera>/image_raw
  std::set<std::pair<std::string, int>> dropped;  // (camera, frame) not written
  std::map<std::pair<std::string, int>, std::string>
      bad_encoding;                               // (camera, frame) -> encoding written instead
  std::set<std::pair<std::string, int>> corrupt;  // (camera, frame): compressed data cut to its first bytes
  std::string gt_topic = "/groundtruth/pose";     // PoseStamped from groundtruth.tum; empty: none
  bool lz4 = false;                               // chunk compression
};

inline std::string BagTopic(const BagSpec& spec, const std::string& camera) {
  const auto it = spec.topic.find(camera);
  return it != spec.topic.end() ? it->second : "/" + camera + "/image_raw";
}

inline ros::Time RosTime(int64_t t_ns) {
  ros::Time time;
  time.sec = static_cast<uint32_t>(t_ns / 1000000000);
  time.nsec = static_cast<uint32_t>(t_ns % 1000000000);
  return time;
}

inline void WriteImageMessage(rosbag::Bag* bag, const std::string& topic, const cv::Mat& grey, int64_t t_ns,
                              uint32_t seq, const std::string& kind, const std::string& bad_encoding,
                              bool corrupt) {
  std_msgs::Header header;
  header.seq = seq;
  header.stamp = RosTime(t_ns);
  header.frame_id = "camera";
  // Received a little after the exposure, as a driver would.
  const ros::Time received = RosTime(t_ns + 2000000);
  if (kind == "png" || kind == "jpeg") {
    sensor_msgs::CompressedImage msg;
    msg.header = header;
    msg.format = kind == "png" ? "mono8; png compressed" : "jpeg";
    std::vector<uint8_t> data;
    cv::imencode(kind == "png" ? ".png" : ".jpg", grey, data);
    if (corrupt) data.resize(40);
    msg.data = data;
    bag->write(topic, received, msg);
    return;
  }
  sensor_msgs::Image msg;
  msg.header = header;
  msg.width = static_cast<uint32_t>(grey.cols);
  msg.height = static_cast<uint32_t>(grey.rows);
  msg.encoding = kind;
  msg.is_bigendian = 0;
  cv::Mat pixels;
  if (kind == "mono8") {
    pixels = grey;
  } else if (kind == "mono16") {
    grey.convertTo(pixels, CV_16UC1, 257.0);  // v * 257: high byte v
  } else {
    cv::cvtColor(grey, pixels, kind == "rgb8" ? cv::COLOR_GRAY2RGB : cv::COLOR_GRAY2BGR);
  }
  if (!bad_encoding.empty()) msg.encoding = bad_encoding;
  msg.step = static_cast<uint32_t>(pixels.cols * pixels.elemSize());
  msg.data.resize(static_cast<size_t>(msg.step) * msg.height);
  for (int y = 0; y < pixels.rows; ++y)
    std::memcpy(msg.data.data() + static_cast<size_t>(y) * msg.step, pixels.ptr(y), msg.step);
  bag->write(topic, received, msg);
}

// Writes `bag_path` from the generic dataset `root`; an unrelated topic
// (/imu/pose_unrelated, PoseStamped) is interleaved as real bags have one.
inline void WriteBagFromGeneric(const std::filesystem::path& root, const std::filesystem::path& bag_path,
                                const BagSpec& spec) {
  const Rig rig = ReadRig(root / "rig.json");
  const FrameTable table = ReadFrameTable(root / "frames.csv");
  rosbag::Bag bag(bag_path.string(), rosbag::bagmode::Write);
  if (spec.lz4) bag.setCompression(rosbag::compression::LZ4);
  for (size_t f = 0; f < table.rows.size(); ++f) {
    const int64_t t_ns = table.rows[f].t_ns;
    for (size_t c = 0; c < rig.cameras.size(); ++c) {
      const std::string& name = rig.cameras[c].name;
      const std::pair<std::string, int> key(name, static_cast<int>(f));
      if (spec.dropped.count(key) != 0) continue;
      const cv::Mat grey = cv::imread((root / table.rows[f].image_paths[c]).string(), cv::IMREAD_GRAYSCALE);
      const auto kind = spec.encoding.find(name);
      const auto bad = spec.bad_encoding.find(key);
      WriteImageMessage(&bag, BagTopic(spec, name), grey, t_ns, static_cast<uint32_t>(f),
                        kind != spec.encoding.end() ? kind->second : "mono8",
                        bad != spec.bad_encoding.end() ? bad->second : "", spec.corrupt.count(key) != 0);
    }
    geometry_msgs::PoseStamped other;
    other.header.stamp = RosTime(t_ns);
    other.pose.orientation.w = 1.0;
    bag.write("/imu/pose_unrelated", RosTime(t_ns + 1000000), other);
  }
  if (!spec.gt_topic.empty()) {
    const Trajectory gt = ReadTrajectory(root / "groundtruth.tum", TrajectoryFormat::kTum);
    for (const StampedPose& pose : gt.poses) {
      geometry_msgs::PoseStamped msg;
      msg.header.stamp = RosTime(pose.t_ns);
      msg.header.frame_id = "world";
      const Eigen::Vector3d& t = pose.world_from_body.translation;
      const Eigen::Quaterniond& q = pose.world_from_body.rotation;
      msg.pose.position.x = t.x();
      msg.pose.position.y = t.y();
      msg.pose.position.z = t.z();
      msg.pose.orientation.x = q.x();
      msg.pose.orientation.y = q.y();
      msg.pose.orientation.z = q.z();
      msg.pose.orientation.w = q.w();
      bag.write(spec.gt_topic, RosTime(pose.t_ns), msg);
    }
  }
  bag.close();
}

inline std::string YamlNumber(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

inline std::string YamlMatrix(const Rigid3d& pose) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = pose.rotation.toRotationMatrix();
  m.topRightCorner<3, 1>() = pose.translation;
  std::string text;
  for (int r = 0; r < 4; ++r) {
    text += "  - [";
    for (int k = 0; k < 4; ++k) text += (k ? ", " : "") + YamlNumber(m(r, k));
    text += "]\n";
  }
  return text;
}

// The Kalibr camchain of a rig of pinhole cameras: cam0, cam1, ... in rig
// order (Kalibr's names), cam0 with T_cam_imu = cam0_from_rig (so that the
// camchain's rig frame is the rig's), rostopic per camera from spec.
inline std::string CamchainOfRig(const Rig& rig, const BagSpec& spec) {
  std::string text;
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    const Camera& camera = rig.cameras[c];
    text += "cam" + std::to_string(c) + ":\n";
    if (c == 0) {
      text += "  T_cam_imu:\n" + YamlMatrix(camera.cam_from_rig);
    } else {
      text += "  T_cn_cnm1:\n" + YamlMatrix(camera.cam_from_rig * rig.cameras[c - 1].cam_from_rig.Inverse());
    }
    text += "  camera_model: pinhole\n  distortion_model: none\n  intrinsics: [";
    for (size_t k = 0; k < 4; ++k) text += (k ? ", " : "") + YamlNumber(camera.params[k]);
    text +=
        "]\n  resolution: [" + std::to_string(camera.width) + ", " + std::to_string(camera.height) + "]\n";
    text += "  rostopic: " + BagTopic(spec, camera.name) + "\n";
  }
  return text;
}

}  // namespace mcvo::testing
