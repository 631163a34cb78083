// Track file reader and writer (byte layout: docs/track-format.md).
//
// All numbers are little-endian and are encoded byte by byte (shifts, not
// memcpy of host integers), so the file is the same on any host. Floats are
// written as their IEEE-754 bit patterns: a round trip is bit-exact.
#include "mcvo/frontend/track_file.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <string_view>
#include <tuple>
#include <utility>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

constexpr std::string_view kMagic = "MCVOTRK1";
// 2: frames end with the cross-camera block. Version 1 files (no such block)
// are still read, as frames without cross-camera matches.
constexpr int kFormatVersion = 3;
constexpr int kOldestFormatVersion = 1;
// frame_index of the end record that closes a complete file.
constexpr int32_t kEndMarker = -1;
// Sanity limits: anything beyond these is a corrupt file, not a big one.
constexpr uint32_t kMaxHeaderBytes = 64u << 20;
constexpr size_t kMaxCameras = 256;
constexpr int kMaxDescriptorSize = 4096;
// Bytes of the fixed part of a camera record (docs/track-format.md); format
// version 3 adds lost_anchor.
constexpr size_t kCameraStatsBytesV2 = 6 * 4 + 2 * 8 + 1;
constexpr size_t kCameraStatsBytes = kCameraStatsBytesV2 + 4;
constexpr size_t kFeatureFixedBytes = 8 + 3 * 4 + 4;
constexpr size_t kPairStatsBytes = size_t{10} * 4;
constexpr size_t kMatchBytes = 1 + 8 + 1 + 2 * 4;

size_t DescriptorElementBytes(int type) { return type == CV_32F ? 4 : 1; }

std::string DescriptorTypeName(int size, int type) {
  if (size == 0) return "none";
  return type == CV_32F ? "f32" : "u8";
}

template <typename T>
void PutUnsigned(std::string* out, T value) {
  for (size_t i = 0; i < sizeof(T); ++i) out->push_back(static_cast<char>((value >> (8 * i)) & 0xFFu));
}
void PutU8(std::string* out, uint8_t v) { out->push_back(static_cast<char>(v)); }
void PutU32(std::string* out, uint32_t v) { PutUnsigned(out, v); }
void PutI32(std::string* out, int32_t v) { PutUnsigned(out, static_cast<uint32_t>(v)); }
void PutU64(std::string* out, uint64_t v) { PutUnsigned(out, v); }
void PutI64(std::string* out, int64_t v) { PutUnsigned(out, static_cast<uint64_t>(v)); }
void PutF32(std::string* out, float v) {
  uint32_t bits = 0;
  std::memcpy(&bits, &v, sizeof(bits));
  PutU32(out, bits);
}
void PutF64(std::string* out, double v) {
  uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof(bits));
  PutU64(out, bits);
}

// Decodes little-endian values from a byte range; the caller has checked the length.
class ByteCursor {
 public:
  explicit ByteCursor(const char* data) : data_(data) {}
  template <typename T>
  T Unsigned() {
    T value = 0;
    for (size_t i = 0; i < sizeof(T); ++i)
      value |= static_cast<T>(static_cast<uint8_t>(data_[pos_ + i])) << (8 * i);
    pos_ += sizeof(T);
    return value;
  }
  uint8_t U8() { return Unsigned<uint8_t>(); }
  uint32_t U32() { return Unsigned<uint32_t>(); }
  int32_t I32() { return static_cast<int32_t>(Unsigned<uint32_t>()); }
  uint64_t U64() { return Unsigned<uint64_t>(); }
  int64_t I64() { return static_cast<int64_t>(Unsigned<uint64_t>()); }
  float F32() {
    const uint32_t bits = U32();
    float v = 0.0f;
    std::memcpy(&v, &bits, sizeof(v));
    return v;
  }
  double F64() {
    const uint64_t bits = U64();
    double v = 0.0;
    std::memcpy(&v, &bits, sizeof(v));
    return v;
  }
  void Bytes(void* dst, size_t n) {
    std::memcpy(dst, data_ + pos_, n);
    pos_ += n;
  }

 private:
  const char* data_;
  size_t pos_ = 0;
};

int32_t ToI32(int value) { return static_cast<int32_t>(value); }

}  // namespace

// ---------------------------------------------------------------------------
// Writer

struct TrackFileWriter::Impl {
  std::filesystem::path path;
  TrackFileHeader header;
  AtomicFileWriter file;
  uint32_t frames = 0;
  std::string buffer;

  Impl(const std::filesystem::path& p, const TrackFileHeader& h) : path(p), header(h), file(p) {}
};

TrackFileWriter::TrackFileWriter(const std::filesystem::path& path, const TrackFileHeader& header) {
  MCVO_CHECK_MSG(header.descriptor_size >= 0 && header.descriptor_size <= kMaxDescriptorSize,
                 "descriptor_size ", header.descriptor_size);
  MCVO_CHECK_MSG(
      header.descriptor_size == 0 || header.descriptor_type == CV_8U || header.descriptor_type == CV_32F,
      "descriptor_type ", header.descriptor_type);
  MCVO_CHECK(!header.camera_names.empty() && header.camera_names.size() <= kMaxCameras);
  impl_ = std::make_unique<Impl>(path, header);

  nlohmann::ordered_json json;
  json["format_version"] = kFormatVersion;
  json["cameras"] = header.camera_names;
  json["descriptor_size"] = header.descriptor_size;
  json["descriptor_type"] = DescriptorTypeName(header.descriptor_size, header.descriptor_type);
  json["detector"] = header.detector;
  json["config"] = header.config_json;
  const std::string text = json.dump();
  std::string head(kMagic);
  PutU32(&head, static_cast<uint32_t>(text.size()));
  head += text;
  impl_->file.stream().write(head.data(), static_cast<std::streamsize>(head.size()));
}

TrackFileWriter::~TrackFileWriter() = default;

void TrackFileWriter::Write(const MultiCameraFrame& frame) {
  const TrackFileHeader& header = impl_->header;
  MCVO_CHECK_MSG(frame.cameras.size() == header.camera_names.size(), "frame has ", frame.cameras.size(),
                 " cameras, the track file ", header.camera_names.size());
  MCVO_CHECK_MSG(frame.frame_index >= 0, "frame_index ", frame.frame_index);
  std::string& out = impl_->buffer;
  out.clear();
  PutI32(&out, ToI32(frame.frame_index));
  PutI64(&out, frame.t_ns);
  const size_t descriptor_bytes =
      static_cast<size_t>(header.descriptor_size) * DescriptorElementBytes(header.descriptor_type);
  for (const CameraFrameResult& camera : frame.cameras) {
    const CameraFrameStats& s = camera.stats;
    PutI32(&out, ToI32(s.tracked));
    PutI32(&out, ToI32(s.new_features));
    PutI32(&out, ToI32(s.lost_lk));
    PutI32(&out, ToI32(s.lost_forward_backward));
    PutI32(&out, ToI32(s.lost_anchor));
    PutI32(&out, ToI32(s.ransac_inliers));
    PutI32(&out, ToI32(s.ransac_outliers));
    PutF64(&out, s.mean_track_length);
    PutF64(&out, s.sfd);
    PutU8(&out, s.image_missing ? 1 : 0);
    const size_t n = camera.features.size();
    PutU32(&out, static_cast<uint32_t>(n));
    if (descriptor_bytes > 0 && n > 0) {
      const cv::Mat& d = camera.descriptors;
      MCVO_CHECK_MSG(d.rows == static_cast<int>(n) && d.cols == header.descriptor_size &&
                         d.depth() == header.descriptor_type && d.channels() == 1,
                     "descriptors ", d.rows, "x", d.cols, " depth ", d.depth(), " for ", n,
                     " features, the track file wants ", header.descriptor_size, " of depth ",
                     header.descriptor_type);
    }
    for (size_t i = 0; i < n; ++i) {
      const TrackedFeature& f = camera.features[i];
      PutU64(&out, f.id);
      PutF32(&out, f.pixel.x());
      PutF32(&out, f.pixel.y());
      PutF32(&out, f.score);
      PutI32(&out, ToI32(f.track_length));
      if (descriptor_bytes == 0) continue;
      const uchar* row = camera.descriptors.ptr<uchar>(static_cast<int>(i));
      if (header.descriptor_type == CV_32F) {
        const float* values = reinterpret_cast<const float*>(row);
        for (int k = 0; k < header.descriptor_size; ++k) PutF32(&out, values[k]);
      } else {
        out.append(reinterpret_cast<const char*>(row), descriptor_bytes);
      }
    }
  }
  // Cross-camera block (format version 2).
  const int num_cameras = static_cast<int>(frame.cameras.size());
  PutU32(&out, static_cast<uint32_t>(frame.cross_pair_stats.size()));
  for (size_t i = 0; i < frame.cross_pair_stats.size(); ++i) {
    const CrossCameraPairStats& p = frame.cross_pair_stats[i];
    MCVO_CHECK_MSG(p.camera_a >= 0 && p.camera_a < p.camera_b && p.camera_b < num_cameras, "pair ",
                   p.camera_a, "-", p.camera_b);
    MCVO_CHECK_MSG(i == 0 || std::make_pair(frame.cross_pair_stats[i - 1].camera_a,
                                            frame.cross_pair_stats[i - 1].camera_b) <
                                 std::make_pair(p.camera_a, p.camera_b),
                   "pair stats not in increasing (camera_a, camera_b) order");
    for (int value : {p.camera_a, p.camera_b, p.features, p.outside_view, p.lost_lk, p.lost_forward_backward,
                      p.lost_epipolar, p.lost_triangulation, p.over_limit, p.matches}) {
      PutI32(&out, ToI32(value));
    }
  }
  PutU32(&out, static_cast<uint32_t>(frame.cross_matches.size()));
  for (size_t i = 0; i < frame.cross_matches.size(); ++i) {
    const CrossCameraMatch& m = frame.cross_matches[i];
    MCVO_CHECK_MSG(m.camera_a >= 0 && m.camera_a < m.camera_b && m.camera_b < num_cameras, "match ",
                   m.camera_a, "-", m.camera_b);
    if (i > 0) {
      const CrossCameraMatch& p = frame.cross_matches[i - 1];
      MCVO_CHECK_MSG(std::tie(p.camera_a, p.camera_b, p.id_a) < std::tie(m.camera_a, m.camera_b, m.id_a),
                     "cross-camera matches not sorted by (camera_a, camera_b, id_a) without duplicates");
    }
    PutU8(&out, static_cast<uint8_t>(m.camera_a));
    PutU64(&out, m.id_a);
    PutU8(&out, static_cast<uint8_t>(m.camera_b));
    PutF32(&out, m.pixel_b.x());
    PutF32(&out, m.pixel_b.y());
  }
  impl_->file.stream().write(out.data(), static_cast<std::streamsize>(out.size()));
  ++impl_->frames;
}

void TrackFileWriter::Commit() {
  std::string end;
  PutI32(&end, kEndMarker);
  PutU32(&end, impl_->frames);
  impl_->file.stream().write(end.data(), static_cast<std::streamsize>(end.size()));
  impl_->file.Commit();
}

// ---------------------------------------------------------------------------
// Reader

struct TrackFileReader::Impl {
  std::filesystem::path path;
  std::ifstream in;
  uint64_t size = 0;    // file size in bytes
  uint64_t offset = 0;  // bytes consumed
  TrackFileHeader header;
  size_t descriptor_bytes = 0;
  bool cross_camera = false;  // frames have the cross-camera block (version >= 2)
  bool lost_anchor = false;   // camera blocks have lost_anchor (version >= 3)
  uint32_t frames = 0;
  bool done = false;
  std::string buffer;

  [[noreturn]] void Corrupt(const std::string& what) const {
    MCVO_THROW_INPUT(path.string(), ": ", what, " (at byte ", offset, ")");
  }
  // Reads exactly n bytes into buffer; a short file is "truncated".
  ByteCursor Read(size_t n) {
    if (n > size - offset)
      MCVO_THROW_INPUT(path.string(), ": truncated at byte ", size, " (expected ", n, " more bytes at byte ",
                       offset, ")");
    buffer.resize(n);
    in.read(buffer.data(), static_cast<std::streamsize>(n));
    if (!in) MCVO_THROW_INPUT(path.string(), ": read error at byte ", offset);
    offset += n;
    return ByteCursor(buffer.data());
  }
  void ParseHeader(const std::string& text);
  // Reads a u32 count of records of record_bytes each that the rest of the
  // file must be able to hold.
  uint32_t ReadCount(int frame_index, size_t record_bytes, const char* what);
  void ReadCrossCameraBlock(int frame_index, MultiCameraFrame* frame);
};

uint32_t TrackFileReader::Impl::ReadCount(int frame_index, size_t record_bytes, const char* what) {
  const uint64_t at = offset;
  const uint32_t n = Read(4).U32();
  if (static_cast<uint64_t>(n) * record_bytes > size - offset) {
    MCVO_THROW_INPUT(path.string(), ": truncated at byte ", size, " (frame ", frame_index, " announces ", n,
                     " ", what, " at byte ", at, ")");
  }
  return n;
}

void TrackFileReader::Impl::ReadCrossCameraBlock(int frame_index, MultiCameraFrame* frame) {
  const int num_cameras = static_cast<int>(header.camera_names.size());
  const uint32_t pairs = ReadCount(frame_index, kPairStatsBytes, "cross-camera pairs");
  frame->cross_pair_stats.resize(pairs);
  for (uint32_t i = 0; i < pairs; ++i) {
    const uint64_t at = offset;
    ByteCursor c = Read(kPairStatsBytes);
    CrossCameraPairStats& p = frame->cross_pair_stats[i];
    p.camera_a = c.I32();
    p.camera_b = c.I32();
    for (int* value : {&p.features, &p.outside_view, &p.lost_lk, &p.lost_forward_backward, &p.lost_epipolar,
                       &p.lost_triangulation, &p.over_limit, &p.matches}) {
      *value = c.I32();
      if (*value < 0) {
        offset = at;
        Corrupt("negative count in cross-camera pair record");
      }
    }
    const bool increasing = i == 0 || std::make_pair(frame->cross_pair_stats[i - 1].camera_a,
                                                     frame->cross_pair_stats[i - 1].camera_b) <
                                          std::make_pair(p.camera_a, p.camera_b);
    if (!(p.camera_a >= 0 && p.camera_a < p.camera_b && p.camera_b < num_cameras) || !increasing) {
      offset = at;
      Corrupt("cross-camera pair " + std::to_string(p.camera_a) + "-" + std::to_string(p.camera_b) +
              ": expected 0 <= camera_a < camera_b < " + std::to_string(num_cameras) +
              ", pairs in increasing order");
    }
  }
  const uint32_t n = ReadCount(frame_index, kMatchBytes, "cross-camera matches");
  ByteCursor c = Read(static_cast<size_t>(n) * kMatchBytes);
  const uint64_t first = offset - static_cast<uint64_t>(n) * kMatchBytes;
  frame->cross_matches.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    CrossCameraMatch& m = frame->cross_matches[i];
    m.camera_a = c.U8();
    m.id_a = c.U64();
    m.camera_b = c.U8();
    const float x = c.F32();
    const float y = c.F32();
    m.pixel_b = Eigen::Vector2f(x, y);
    const bool increasing =
        i == 0 || std::tie(frame->cross_matches[i - 1].camera_a, frame->cross_matches[i - 1].camera_b,
                           frame->cross_matches[i - 1].id_a) < std::tie(m.camera_a, m.camera_b, m.id_a);
    if (!(m.camera_a < m.camera_b && m.camera_b < num_cameras) || !increasing) {
      offset = first + static_cast<uint64_t>(i) * kMatchBytes;
      Corrupt("cross-camera match " + std::to_string(i) + " (camera " + std::to_string(m.camera_a) + " id " +
              std::to_string(m.id_a) + " in camera " + std::to_string(m.camera_b) +
              "): expected camera_a < camera_b < " + std::to_string(num_cameras) +
              ", sorted by (camera_a, camera_b, id) without duplicates");
    }
  }
}

void TrackFileReader::Impl::ParseHeader(const std::string& text) {
  try {
    const nlohmann::json json = nlohmann::json::parse(text);
    const nlohmann::json& version = json.at("format_version");
    if (!version.is_number_integer() || version.get<int64_t>() < kOldestFormatVersion ||
        version.get<int64_t>() > kFormatVersion) {
      Corrupt("unsupported format_version " + version.dump() + " (this reader: " +
              std::to_string(kOldestFormatVersion) + " to " + std::to_string(kFormatVersion) + ")");
    }
    header.format_version = version.get<int>();
    cross_camera = header.format_version >= 2;
    lost_anchor = header.format_version >= 3;
    header.camera_names = json.at("cameras").get<std::vector<std::string>>();
    header.descriptor_size = json.at("descriptor_size").get<int>();
    const std::string type = json.at("descriptor_type").get<std::string>();
    header.detector = json.at("detector").get<std::string>();
    header.config_json = json.at("config").get<std::string>();
    if (header.camera_names.empty() || header.camera_names.size() > kMaxCameras) {
      Corrupt("header: cameras: expected 1.." + std::to_string(kMaxCameras) + " names");
    }
    if (header.descriptor_size < 0 || header.descriptor_size > kMaxDescriptorSize) {
      Corrupt("header: descriptor_size: expected 0.." + std::to_string(kMaxDescriptorSize));
    }
    if (type == "f32") {
      header.descriptor_type = CV_32F;
    } else if (type == "u8" || type == "none") {
      // CV_8U is 0, which is also what "none" stores (descriptor_size 0 tells them apart).
      header.descriptor_type = CV_8U;
    } else {
      Corrupt("header: descriptor_type: expected none, u8 or f32, got \"" + type + "\"");
    }
    if ((type == "none") != (header.descriptor_size == 0)) {
      Corrupt("header: descriptor_type \"" + type + "\" does not fit descriptor_size " +
              std::to_string(header.descriptor_size));
    }
  } catch (const nlohmann::json::exception& e) {
    Corrupt(std::string("header: ") + e.what());
  }
  descriptor_bytes =
      static_cast<size_t>(header.descriptor_size) * DescriptorElementBytes(header.descriptor_type);
}

TrackFileReader::TrackFileReader(const std::filesystem::path& path) : impl_(std::make_unique<Impl>()) {
  Impl& r = *impl_;
  r.path = path;
  std::error_code error;
  r.size = std::filesystem::file_size(path, error);
  r.in.open(path, std::ios::binary);
  if (error || !r.in) MCVO_THROW_INPUT(path.string(), ": cannot open track file");
  ByteCursor magic = r.Read(kMagic.size());
  std::array<char, kMagic.size()> bytes{};
  magic.Bytes(bytes.data(), bytes.size());
  if (std::string_view(bytes.data(), bytes.size()) != kMagic) {
    r.offset = 0;
    r.Corrupt("not an mcvo track file (the first 8 bytes are not \"MCVOTRK1\")");
  }
  const uint32_t header_bytes = r.Read(4).U32();
  if (header_bytes > kMaxHeaderBytes)
    r.Corrupt("header length " + std::to_string(header_bytes) + " is not sane");
  r.Read(header_bytes);
  r.ParseHeader(r.buffer);
}

TrackFileReader::~TrackFileReader() = default;

const TrackFileHeader& TrackFileReader::header() const { return impl_->header; }

std::optional<MultiCameraFrame> TrackFileReader::Next() {
  Impl& r = *impl_;
  if (r.done) return std::nullopt;
  if (r.offset == r.size) r.Corrupt("truncated at byte " + std::to_string(r.size) + ": no end record");
  const int32_t frame_index = r.Read(4).I32();
  if (frame_index == kEndMarker) {
    const uint32_t count = r.Read(4).U32();
    if (count != r.frames) {
      r.Corrupt("end record counts " + std::to_string(count) + " frames, the file has " +
                std::to_string(r.frames));
    }
    if (r.offset != r.size) r.Corrupt("unexpected bytes after the end record");
    r.done = true;
    return std::nullopt;
  }
  if (frame_index < 0) r.Corrupt("negative frame_index " + std::to_string(frame_index));
  MultiCameraFrame frame;
  frame.frame_index = frame_index;
  frame.t_ns = r.Read(8).I64();
  const size_t feature_bytes = kFeatureFixedBytes + r.descriptor_bytes;
  const int descriptor_depth = r.header.descriptor_type;
  frame.cameras.resize(r.header.camera_names.size());
  for (CameraFrameResult& camera : frame.cameras) {
    ByteCursor c = r.Read((r.lost_anchor ? kCameraStatsBytes : kCameraStatsBytesV2) + 4);
    CameraFrameStats& s = camera.stats;
    s.tracked = c.I32();
    s.new_features = c.I32();
    s.lost_lk = c.I32();
    s.lost_forward_backward = c.I32();
    if (r.lost_anchor) s.lost_anchor = c.I32();
    s.ransac_inliers = c.I32();
    s.ransac_outliers = c.I32();
    s.mean_track_length = c.F64();
    s.sfd = c.F64();
    const uint8_t missing = c.U8();
    if (missing > 1) r.Corrupt("image_missing must be 0 or 1, got " + std::to_string(missing));
    s.image_missing = missing == 1;
    const uint32_t n = c.U32();
    // A count that the rest of the file cannot hold is corruption, not a big frame.
    if (static_cast<uint64_t>(n) * feature_bytes > r.size - r.offset) {
      MCVO_THROW_INPUT(r.path.string(), ": truncated at byte ", r.size, " (frame ", frame_index,
                       " announces ", n, " features at byte ", r.offset, ")");
    }
    if (n > static_cast<uint32_t>(std::numeric_limits<int>::max())) r.Corrupt("feature count is not sane");
    ByteCursor f = r.Read(n * feature_bytes);
    camera.features.resize(n);
    if (r.descriptor_bytes > 0 && n > 0)
      camera.descriptors.create(static_cast<int>(n), r.header.descriptor_size, descriptor_depth);
    for (uint32_t i = 0; i < n; ++i) {
      TrackedFeature& feature = camera.features[i];
      feature.id = f.U64();
      const float x = f.F32();
      const float y = f.F32();
      feature.pixel = Eigen::Vector2f(x, y);
      feature.score = f.F32();
      feature.track_length = f.I32();
      if (r.descriptor_bytes == 0) continue;
      uchar* row = camera.descriptors.ptr<uchar>(static_cast<int>(i));
      if (descriptor_depth == CV_32F) {
        float* values = reinterpret_cast<float*>(row);
        for (int k = 0; k < r.header.descriptor_size; ++k) values[k] = f.F32();
      } else {
        f.Bytes(row, r.descriptor_bytes);
      }
    }
  }
  if (r.cross_camera) r.ReadCrossCameraBlock(frame_index, &frame);
  ++r.frames;
  return frame;
}

}  // namespace mcvo
