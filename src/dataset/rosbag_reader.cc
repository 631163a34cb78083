// ROS1 bags (docs/datasets.md, "ROS bags"), read with Debian's rosbag_storage:
//
//   --dataset run.bag --calib camchain.yaml | rig.json
//       [--topics cam0=/cam0/image_raw,...] [--gt-topic /pose | --gt FILE]
//
// One image topic per camera: sensor_msgs/Image (mono8, mono16, bgr8, rgb8,
// bgra8, rgba8, 8UC1, 16UC1) or sensor_msgs/CompressedImage (any format
// OpenCV decodes: png, jpeg). Time: header.stamp. The topics' messages are
// synchronised as the Kalibr layout's images (camera_sync.h). Ground truth,
// world_from_rig: a geometry_msgs/PoseStamped, geometry_msgs/TransformStamped
// or nav_msgs/Odometry topic, or a trajectory file.
//
// Streaming: opening reads every image message once (its header and, for raw
// images, encoding and size are checked) and keeps the bag open with the
// index of its messages (rosbag::MessageInstance). Frames list the images as
// <bag>/<topic without the leading />/<message index> (the index within the
// topic, in bag order), a registered image container (image_container.h):
// FrameStream decodes each from the bag when it is needed. rosbag::Bag reads
// are not thread-safe: a mutex guards them, the decode runs outside it.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "camera_sync.h"
#include "kalibr_camchain.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/dataset/image_container.h"
#include "mcvo/dataset/image_file.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/sha256.h"
#include "mcvo/util/strings.h"
#include "rig_mask.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
namespace ser = ros::serialization;

constexpr const char* kImageType = "sensor_msgs/Image";
constexpr const char* kCompressedType = "sensor_msgs/CompressedImage";

// Where a message is, for errors: "<bag>: topic /cam0/image_raw, message 12".
std::string Where(const fs::path& bag, const std::string& topic, size_t index) {
  return StrCat(bag.string(), ": topic ", topic, ", message ", index);
}

bool IsFile(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

int64_t StampNs(const ros::Time& stamp) {
  return static_cast<int64_t>(stamp.sec) * 1000000000 + static_cast<int64_t>(stamp.nsec);
}

// A message's serialized bytes (rosbag's Stream concept: advance(n) hands out n bytes).
struct ByteSink {
  std::vector<uint8_t>* bytes;
  uint8_t* advance(uint32_t n) {
    const size_t old = bytes->size();
    bytes->resize(old + n);
    return bytes->data() + old;
  }
};

// A sensor_msgs/Image or CompressedImage, parsed in place from its bytes.
struct ImageMessage {
  int64_t t_ns = 0;
  uint32_t height = 0, width = 0, step = 0;
  uint8_t big_endian = 0;
  std::string encoding;  // Image: encoding; CompressedImage: format
  const uint8_t* data = nullptr;
  uint32_t size = 0;
};

// Throws ros::serialization::StreamOverrunException on a short message.
ImageMessage ParseImageMessage(const std::vector<uint8_t>& bytes, bool compressed) {
  ser::IStream in(const_cast<uint8_t*>(bytes.data()), static_cast<uint32_t>(bytes.size()));
  std_msgs::Header header;
  ser::deserialize(in, header);
  ImageMessage m;
  m.t_ns = StampNs(header.stamp);
  if (!compressed) {
    in.next(m.height);
    in.next(m.width);
  }
  in.next(m.encoding);
  if (!compressed) {
    in.next(m.big_endian);
    in.next(m.step);
  }
  in.next(m.size);
  m.data = in.advance(m.size);
  return m;
}

struct Encoding {
  const char* name;
  int type;    // OpenCV type of the stored pixels
  int to_bgr;  // cv::cvtColor code to BGR(A), or -1
};
constexpr Encoding kEncodings[] = {
    {"mono8", CV_8UC1, -1},   {"8UC1", CV_8UC1, -1},
    {"mono16", CV_16UC1, -1}, {"16UC1", CV_16UC1, -1},
    {"bgr8", CV_8UC3, -1},    {"rgb8", CV_8UC3, cv::COLOR_RGB2BGR},
    {"bgra8", CV_8UC4, -1},   {"rgba8", CV_8UC4, cv::COLOR_RGBA2BGRA},
};
constexpr const char* kEncodingList = "mono8, mono16, bgr8, rgb8, bgra8, rgba8, 8UC1, 16UC1";

const Encoding* FindEncoding(const std::string& name) {
  for (const Encoding& e : kEncodings)
    if (name == e.name) return &e;
  return nullptr;
}

bool IsCompressedFormat(std::string format) {
  std::transform(format.begin(), format.end(), format.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return format.find("png") != std::string::npos || format.find("jpeg") != std::string::npos ||
         format.find("jpg") != std::string::npos;
}

// What is wrong with a raw image's layout, or empty.
std::string RawImageError(const ImageMessage& m, int width, int height) {
  const Encoding* encoding = FindEncoding(m.encoding);
  if (encoding == nullptr)
    return StrCat("encoding '", m.encoding, "' is not supported (", kEncodingList, ")");
  if (static_cast<int>(m.width) != width || static_cast<int>(m.height) != height) {
    return StrCat("image is ", m.width, " x ", m.height, " px but the camera expects ", width, " x ", height);
  }
  const uint64_t row = static_cast<uint64_t>(m.width) * CV_ELEM_SIZE(encoding->type);
  if (m.step < row) return StrCat("step ", m.step, " is less than a row of ", row, " bytes");
  if (static_cast<uint64_t>(m.size) < static_cast<uint64_t>(m.step) * m.height)
    return StrCat("data holds ", m.size, " bytes, step x height needs ",
                  static_cast<uint64_t>(m.step) * m.height);
  return "";
}

cv::Mat DecodeRaw(const ImageMessage& m) {
  const Encoding* encoding = FindEncoding(m.encoding);
  const cv::Mat view(static_cast<int>(m.height), static_cast<int>(m.width), encoding->type,
                     const_cast<uint8_t*>(m.data), m.step);
  cv::Mat image;
  if (encoding->to_bgr >= 0) {
    cv::cvtColor(view, image, encoding->to_bgr);
  } else {
    image = view.clone();
  }
  if (CV_MAT_DEPTH(encoding->type) == CV_16U && m.big_endian != 0) {  // this machine: little-endian
    for (int y = 0; y < image.rows; ++y) {
      uint16_t* row = image.ptr<uint16_t>(y);
      for (int x = 0; x < image.cols * image.channels(); ++x)
        row[x] = static_cast<uint16_t>((row[x] >> 8) | (row[x] << 8));
    }
  }
  return image;
}

// The images of one camera's topic, in bag order (the message index).
struct ImageTopic {
  std::string topic;
  std::string camera;
  int width = 0, height = 0;
  std::vector<rosbag::MessageInstance> messages;
  std::vector<bool> compressed;
};

class BagImages final : public ImageContainer {
 public:
  explicit BagImages(const fs::path& path) : path_(path) {
    try {
      bag_.open(path.string(), rosbag::bagmode::Read);
    } catch (const std::exception& e) {
      MCVO_THROW_INPUT(path.string(),
                       ": cannot read the ROS bag (truncated, unindexed or not a bag?): ", e.what());
    }
  }

  const fs::path& path() const { return path_; }
  const rosbag::Bag& bag() const { return bag_; }

  // The bytes of a message; the bag read under the lock.
  std::vector<uint8_t> Read(const rosbag::MessageInstance& m, const std::string& topic, size_t index) const {
    std::vector<uint8_t> bytes;
    try {
      std::lock_guard<std::mutex> lock(mutex_);
      ByteSink sink{&bytes};
      m.write(sink);
    } catch (const std::exception& e) {
      MCVO_THROW_INPUT(Where(path_, topic, index), ": cannot read the message: ", e.what());
    }
    return bytes;
  }

  void AddTopic(ImageTopic topic) { topics_[topic.topic.substr(1)] = std::move(topic); }

  cv::Mat Decode(const fs::path& member) const override {
    const auto [topic, index] = Locate(member);
    const std::vector<uint8_t> bytes = Read(topic->messages[index], topic->topic, index);
    const std::string where = Where(path_, topic->topic, index);
    const bool compressed = topic->compressed[index];
    ImageMessage m;
    try {
      m = ParseImageMessage(bytes, compressed);
    } catch (const std::exception& e) {
      MCVO_THROW_INPUT(where, ": cannot deserialize ", compressed ? kCompressedType : kImageType, ": ",
                       e.what());
    }
    cv::Mat image;
    if (!compressed) {
      const std::string error = RawImageError(m, topic->width, topic->height);
      if (!error.empty()) MCVO_THROW_INPUT(where, ": ", error);
      image = DecodeRaw(m);
    } else {
      image = DecodePng(m.data, m.size);
      try {
        if (image.empty()) {
          const cv::Mat data(1, static_cast<int>(m.size), CV_8UC1, const_cast<uint8_t*>(m.data));
          image = cv::imdecode(data, cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH);
        }
      } catch (const cv::Exception& e) {
        MCVO_THROW_INPUT(where, ": cannot decode the ", m.encoding, " image: ", e.what());
      }
      if (image.empty())
        MCVO_THROW_INPUT(where, ": cannot decode the ", m.encoding, " image (corrupt or truncated)");
      if (image.cols != topic->width || image.rows != topic->height) {
        MCVO_THROW_INPUT(where, ": image is ", image.cols, " x ", image.rows, " px but camera ",
                         topic->camera, " expects ", topic->width, " x ", topic->height);
      }
    }
    return image;
  }

  std::string Sha256(const fs::path& member) const override {
    const auto [topic, index] = Locate(member);
    const std::vector<uint8_t> bytes = Read(topic->messages[index], topic->topic, index);
    return Sha256Hex(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  }

 private:
  std::pair<const ImageTopic*, size_t> Locate(const fs::path& member) const {
    const auto it = topics_.find(member.parent_path().generic_string());
    const std::optional<int64_t> index = ParseInt64(member.filename().string());
    if (it == topics_.end() || !index || *index < 0 ||
        static_cast<size_t>(*index) >= it->second.messages.size()) {
      MCVO_THROW_INPUT(path_.string(), ": no image message ", member.generic_string(), " in the bag");
    }
    return {&it->second, static_cast<size_t>(*index)};
  }

  fs::path path_;
  mutable std::mutex mutex_;
  rosbag::Bag bag_;                           // its reads change its buffers: under mutex_
  std::map<std::string, ImageTopic> topics_;  // by topic without its leading '/'
};

std::string TopicList(const rosbag::Bag& bag) {
  rosbag::View all(bag);
  std::set<std::string> names;
  for (const rosbag::ConnectionInfo* c : all.getConnections())
    names.insert(c->topic + " (" + c->datatype + ")");
  std::string list;
  for (const std::string& name : names) list += (list.empty() ? "" : ", ") + name;
  return list.empty() ? "none" : list;
}

// Messages per second over the span of sorted times; 0 when under two.
std::string Rate(const std::vector<int64_t>& sorted) {
  if (sorted.size() < 2 || sorted.back() <= sorted.front()) return "rate n/a";
  const double seconds = static_cast<double>(sorted.back() - sorted.front()) * 1e-9;
  return FormatFixed(static_cast<double>(sorted.size() - 1) / seconds, 2) + " Hz";
}

// Indexes the image topic of one camera: every message's type, header.stamp
// and (raw images) layout checked. Its images in time order for the sync.
dataset_internal::CameraImages IndexImageTopic(BagImages* bag, const Camera& camera, const std::string& topic,
                                               std::vector<std::string>* log) {
  const fs::path& path = bag->path();
  rosbag::View view(bag->bag(), rosbag::TopicQuery(topic));
  if (view.size() == 0) {
    MCVO_THROW_INPUT(path.string(), ": topic ", topic, " (camera ", camera.name,
                     ") has no message in the bag (topics: ", TopicList(bag->bag()), ")");
  }
  const std::string image_md5 = ros::message_traits::MD5Sum<sensor_msgs::Image>::value();
  const std::string compressed_md5 = ros::message_traits::MD5Sum<sensor_msgs::CompressedImage>::value();
  ImageTopic images;
  images.topic = topic;
  images.camera = camera.name;
  images.width = camera.width;
  images.height = camera.height;
  std::vector<std::pair<int64_t, size_t>> by_time;
  std::map<std::string, size_t> encodings;
  for (const rosbag::MessageInstance& m : view) {
    const size_t index = images.messages.size();
    const std::string where = Where(path, topic, index);
    const bool compressed = m.getDataType() == kCompressedType;
    if (!compressed && m.getDataType() != kImageType) {
      MCVO_THROW_INPUT(where, ": type ", m.getDataType(), " (expected ", kImageType, " or ", kCompressedType,
                       ")");
    }
    if (m.getMD5Sum() != (compressed ? compressed_md5 : image_md5)) {
      MCVO_THROW_INPUT(where, ": ", m.getDataType(), " of another definition (md5sum ", m.getMD5Sum(),
                       ", expected ", compressed ? compressed_md5 : image_md5, ")");
    }
    const std::vector<uint8_t> bytes = bag->Read(m, topic, index);
    ImageMessage parsed;
    try {
      parsed = ParseImageMessage(bytes, compressed);
    } catch (const std::exception& e) {
      MCVO_THROW_INPUT(where, ": cannot deserialize ", m.getDataType(), ": ", e.what());
    }
    if (compressed && !IsCompressedFormat(parsed.encoding)) {
      MCVO_THROW_INPUT(where, ": compressed format '", parsed.encoding, "' is not supported (png, jpeg)");
    }
    if (!compressed) {
      const std::string error = RawImageError(parsed, camera.width, camera.height);
      if (!error.empty()) MCVO_THROW_INPUT(where, ": ", error, " (camera ", camera.name, ")");
    }
    ++encodings[compressed ? "compressed " + parsed.encoding : parsed.encoding];
    by_time.emplace_back(parsed.t_ns, index);
    images.messages.push_back(m);
    images.compressed.push_back(compressed);
  }
  std::stable_sort(by_time.begin(), by_time.end());
  dataset_internal::CameraImages out;
  out.name = camera.name;
  const fs::path topic_path = path / topic.substr(1);
  for (size_t k = 0; k < by_time.size(); ++k) {
    if (k > 0 && by_time[k].first == by_time[k - 1].first) {
      MCVO_THROW_INPUT(Where(path, topic, by_time[k].second), ": header.stamp ",
                       FormatNsAsSeconds(by_time[k].first), " s equals that of message ",
                       by_time[k - 1].second);
    }
    out.t_ns.push_back(by_time[k].first);
    out.images.push_back(topic_path / std::to_string(by_time[k].second));
  }
  std::string kinds;
  for (const auto& [name, count] : encodings) kinds += StrCat(kinds.empty() ? "" : ", ", name, " ", count);
  log->push_back(StrCat("rosbag: camera ", camera.name, " <- ", topic, ": ", images.messages.size(),
                        " images (", kinds, "), ", Rate(out.t_ns), " by header.stamp"));
  bag->AddTopic(std::move(images));
  return out;
}

template <class Message>
boost::shared_ptr<Message> Instantiate(const rosbag::MessageInstance& m, const std::string& where) {
  try {
    return m.instantiate<Message>();
  } catch (const std::exception& e) {
    MCVO_THROW_INPUT(where, ": cannot read the message: ", e.what());
  }
}

Rigid3d PoseOf(const geometry_msgs::Point& t, const geometry_msgs::Quaternion& q, const std::string& where) {
  const Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
  const double norm = rotation.norm();
  if (!std::isfinite(norm) || std::abs(norm - 1.0) > 1e-3 || !std::isfinite(t.x + t.y + t.z)) {
    MCVO_THROW_INPUT(where, ": pose is not finite or its quaternion not unit (norm ", FormatDouble(norm),
                     ")");
  }
  return Rigid3d(rotation.normalized(), Eigen::Vector3d(t.x, t.y, t.z));
}

// world_from_rig from a pose topic, in time order.
Trajectory ReadGroundTruthTopic(const BagImages& bag, const std::string& topic,
                                std::vector<std::string>* log) {
  rosbag::View view(bag.bag(), rosbag::TopicQuery(topic));
  if (view.size() == 0) {
    MCVO_THROW_INPUT(bag.path().string(), ": ground-truth topic ", topic,
                     " has no message in the bag (topics: ", TopicList(bag.bag()), ")");
  }
  Trajectory trajectory;
  trajectory.has_time = true;
  std::string type;
  size_t index = 0;
  for (const rosbag::MessageInstance& m : view) {
    const std::string where = Where(bag.path(), topic, index++);
    type = m.getDataType();
    StampedPose pose;
    if (auto p = Instantiate<geometry_msgs::PoseStamped>(m, where)) {
      pose.t_ns = StampNs(p->header.stamp);
      pose.world_from_body = PoseOf(p->pose.position, p->pose.orientation, where);
    } else if (auto o = Instantiate<nav_msgs::Odometry>(m, where)) {
      pose.t_ns = StampNs(o->header.stamp);
      pose.world_from_body = PoseOf(o->pose.pose.position, o->pose.pose.orientation, where);
    } else if (auto tf = Instantiate<geometry_msgs::TransformStamped>(m, where)) {
      geometry_msgs::Point t;
      t.x = tf->transform.translation.x;
      t.y = tf->transform.translation.y;
      t.z = tf->transform.translation.z;
      pose.t_ns = StampNs(tf->header.stamp);
      pose.world_from_body = PoseOf(t, tf->transform.rotation, where);
    } else {
      MCVO_THROW_INPUT(where, ": type ", m.getDataType(),
                       " is not a pose (geometry_msgs/PoseStamped, geometry_msgs/TransformStamped, "
                       "nav_msgs/Odometry)");
    }
    trajectory.poses.push_back(pose);
  }
  std::stable_sort(trajectory.poses.begin(), trajectory.poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.t_ns < b.t_ns; });
  log->push_back(StrCat("ground truth: topic ", topic, " (", type, ", ", trajectory.poses.size(),
                        " poses, world_from_rig)"));
  return trajectory;
}

// The rig (all cameras of the calibration file) and each camera's default topic.
Rig ReadCalibration(const fs::path& calib, std::vector<std::string>* topics, std::vector<std::string>* log) {
  if (!IsFile(calib)) MCVO_THROW_INPUT(calib.string(), ": calibration file ", WhyNotAFile(calib));
  Rig rig;
  if (calib.extension() == ".json") {
    rig = ReadRig(calib);
    topics->assign(rig.cameras.size(), "");
    log->push_back("rosbag: calibration " + calib.string() + " (rig.json)");
  } else {
    rig.cameras = dataset_internal::ReadCamchain(calib, log, topics);
    log->push_back("rosbag: calibration " + calib.string() + " (Kalibr camchain)");
  }
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    std::string& topic = (*topics)[c];
    if (topic.empty()) topic = "/" + rig.cameras[c].name + "/image_raw";
    if (topic[0] != '/') topic = "/" + topic;
  }
  return rig;
}

void LogBagSummary(const BagImages& bag, std::vector<std::string>* log) {
  rosbag::View all(bag.bag());
  std::map<std::string, std::pair<std::string, std::vector<int64_t>>> topics;  // type, receive times
  for (const rosbag::ConnectionInfo* c : all.getConnections()) topics[c->topic].first = c->datatype;
  for (const rosbag::MessageInstance& m : all) topics[m.getTopic()].second.push_back(StampNs(m.getTime()));
  log->push_back(StrCat(
      "rosbag: ", bag.path().string(), ": ", all.size(), " messages on ", topics.size(), " topics, ",
      FormatFixed(static_cast<double>(StampNs(all.getEndTime()) - StampNs(all.getBeginTime())) * 1e-9, 3),
      " s"));
  for (auto& [topic, info] : topics) {
    std::sort(info.second.begin(), info.second.end());
    log->push_back(StrCat("rosbag: topic ", topic, ": ", info.first, ", ", info.second.size(), " messages, ",
                          Rate(info.second), " by receive time"));
  }
}

}  // namespace

DatasetIndex ReadRosbagDataset(const DatasetOptions& options) {
  DatasetIndex index;
  index.format = "rosbag";
  index.root = options.root;
  index.name = options.root.stem().string();
  if (options.calib.empty())
    throw UsageError("calib: a ROS bag needs its calibration (a Kalibr camchain.yaml or a rig.json)");
  if (!IsFile(options.root)) MCVO_THROW_INPUT(options.root.string(), ": ROS bag ", WhyNotAFile(options.root));
  std::vector<std::string> default_topics;
  const Rig all = ReadCalibration(options.calib, &default_topics, &index.log);
  for (const auto& [name, topic] : options.topics) {
    if (all.FindCamera(name) < 0)
      throw UsageError(StrCat("topics: '", name, "' is not a camera of ", options.calib.string()));
  }
  std::vector<std::string> selected = options.cameras;
  if (selected.empty())
    for (const Camera& camera : all.cameras) selected.push_back(camera.name);

  auto bag = std::make_shared<BagImages>(options.root);
  LogBagSummary(*bag, &index.log);
  std::vector<dataset_internal::CameraImages> streams;
  for (const std::string& name : selected) {
    const int c = all.FindCamera(name);
    if (c < 0) throw UsageError(StrCat("cameras: '", name, "' is not a camera of ", options.calib.string()));
    const Camera& camera = all.cameras[static_cast<size_t>(c)];
    std::string topic = default_topics[static_cast<size_t>(c)];
    for (const auto& [camera_name, given] : options.topics)
      if (camera_name == name) topic = given[0] == '/' ? given : "/" + given;
    index.rig.cameras.push_back(camera);
    index.masks.push_back(camera.mask_path.empty() ? cv::Mat() : dataset_internal::ReadRigMask(camera));
    streams.push_back(IndexImageTopic(bag.get(), camera, topic, &index.log));
  }
  dataset_internal::SyncResult sync =
      dataset_internal::SynchronizeCameras(streams, options.sync_tolerance_s, options.missing_images);
  index.log.insert(index.log.end(), sync.log.begin(), sync.log.end());
  index.frames = std::move(sync.frames);
  if (index.frames.empty()) {
    MCVO_THROW_INPUT(options.root.string(), ": no frame has an image from every camera within ",
                     options.sync_tolerance_s, " s");
  }
  if (!options.gt_topic.empty()) {
    index.ground_truth = ReadGroundTruthTopic(*bag, options.gt_topic, &index.log);
  } else if (!options.gt_file.empty()) {
    index.ground_truth = ReadTrajectory(options.gt_file, DetectTrajectoryFormat(options.gt_file));
    index.log.push_back(StrCat("ground truth: ", options.gt_file.string(), " (",
                               index.ground_truth->poses.size(), " poses, world_from_rig)"));
  } else {
    index.log.push_back("ground truth: none (no --gt-topic or --gt)");
  }
  index.image_container = RegisterImageContainer(options.root, bag);
  for (const std::string& line : index.log) MCVO_LOG(kDebug, line);
  return index;
}

}  // namespace mcvo
