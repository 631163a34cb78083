// Track files: bit-exact round trip, and one-line errors naming the file for
// truncated or foreign files.
#include "mcvo/frontend/track_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <tuple>

#include <opencv2/core.hpp>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

fs::path TempFile(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / "mcvo_track_file_test";
  fs::create_directories(dir);
  return dir / name;
}

// Two cameras; the second has no image in frame 1. Awkward floats (negative
// zero, denormal, NaN payload) check the bit-exact round trip.
std::vector<MultiCameraFrame> MakeFrames(int descriptor_size, int descriptor_type) {
  std::vector<MultiCameraFrame> frames;
  uint64_t next_id = 1;
  for (int f = 0; f < 3; ++f) {
    MultiCameraFrame frame;
    frame.frame_index = f * 2;
    frame.t_ns = 1000000000LL * f + 123;
    for (int c = 0; c < 2; ++c) {
      CameraFrameResult camera;
      const bool missing = c == 1 && f == 1;
      camera.stats.image_missing = missing;
      const int n = missing ? 0 : 3 + f + c;
      for (int i = 0; i < n; ++i) {
        TrackedFeature feature;
        feature.id = next_id++ + (uint64_t{1} << 40);
        feature.pixel =
            Eigen::Vector2f(10.5f * static_cast<float>(i) + 0.1f, -0.0f + static_cast<float>(f) / 3.0f);
        feature.score = i == 0 ? std::numeric_limits<float>::denorm_min() : 1.0f / static_cast<float>(i + 1);
        feature.track_length = 1 + i;
        camera.features.push_back(feature);
      }
      if (descriptor_size > 0 && n > 0) {
        camera.descriptors.create(n, descriptor_size, descriptor_type);
        cv::randu(camera.descriptors, 0, 255);
      }
      camera.stats.tracked = f;
      camera.stats.new_features = n - f;
      camera.stats.lost_lk = 7;
      camera.stats.lost_forward_backward = 2;
      camera.stats.lost_anchor = 5 + c;
      camera.stats.ransac_inliers = 20 + c;
      camera.stats.ransac_outliers = 3;
      camera.stats.mean_track_length = 1.0 / 3.0 + f;
      camera.stats.sfd = std::sqrt(2.0) * c;
      camera.stats.seconds_lk = 0.5;  // never stored
      frame.cameras.push_back(camera);
    }
    // Cross-camera matches of camera 0's features in camera 1 (none in
    // frame 1, where camera 1 has no image).
    CrossCameraPairStats pair;
    pair.camera_a = 0;
    pair.camera_b = 1;
    pair.features = static_cast<int>(frame.cameras[0].features.size());
    if (f != 1) {
      for (size_t i = 0; i < frame.cameras[0].features.size(); i += 2) {
        CrossCameraMatch match;
        match.camera_a = 0;
        match.id_a = frame.cameras[0].features[i].id;
        match.camera_b = 1;
        match.pixel_b = Eigen::Vector2f(0.25f * static_cast<float>(i) - 0.0f, 1.0f / 7.0f);
        frame.cross_matches.push_back(match);
      }
      pair.matches = static_cast<int>(frame.cross_matches.size());
      pair.lost_epipolar = 1;
      pair.outside_view = pair.features - pair.lost_epipolar - pair.matches;
    }
    pair.seconds = 0.25;  // never stored
    frame.cross_pair_stats.push_back(pair);
    frames.push_back(frame);
  }
  frames[0].cameras[0].features[1].pixel.x() = std::numeric_limits<float>::quiet_NaN();
  frames[2].cross_matches[0].pixel_b.y() = std::numeric_limits<float>::denorm_min();
  return frames;
}

TrackFileHeader MakeHeader(int descriptor_size, int descriptor_type) {
  TrackFileHeader header;
  header.camera_names = {"image_00", "image_01"};
  header.descriptor_size = descriptor_size;
  header.descriptor_type = descriptor_size > 0 ? descriptor_type : 0;
  header.detector = "xfeat";
  header.config_json = "{\n  \"frontend\": {\"detector\": \"xfeat\"}\n}\n";
  return header;
}

void WriteFrames(const fs::path& path, const TrackFileHeader& header,
                 const std::vector<MultiCameraFrame>& frames) {
  TrackFileWriter writer(path, header);
  for (const MultiCameraFrame& frame : frames) writer.Write(frame);
  writer.Commit();
}

bool SameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(a)) == 0; }
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(a)) == 0; }

void ExpectRoundTrip(int descriptor_size, int descriptor_type) {
  const fs::path path = TempFile("round_trip_" + std::to_string(descriptor_size) + ".bin");
  const TrackFileHeader header = MakeHeader(descriptor_size, descriptor_type);
  const std::vector<MultiCameraFrame> frames = MakeFrames(descriptor_size, descriptor_type);
  WriteFrames(path, header, frames);

  TrackFileReader reader(path);
  EXPECT_EQ(reader.header().camera_names, header.camera_names);
  EXPECT_EQ(reader.header().descriptor_size, header.descriptor_size);
  EXPECT_EQ(reader.header().descriptor_type, header.descriptor_type);
  EXPECT_EQ(reader.header().detector, header.detector);
  EXPECT_EQ(reader.header().config_json, header.config_json);
  EXPECT_EQ(reader.header().format_version, 3);
  for (const MultiCameraFrame& expected : frames) {
    const std::optional<MultiCameraFrame> got = reader.Next();
    ASSERT_TRUE(got.has_value());
    EXPECT_EQ(got->frame_index, expected.frame_index);
    EXPECT_EQ(got->t_ns, expected.t_ns);
    ASSERT_EQ(got->cameras.size(), expected.cameras.size());
    for (size_t c = 0; c < expected.cameras.size(); ++c) {
      const CameraFrameResult& e = expected.cameras[c];
      const CameraFrameResult& g = got->cameras[c];
      EXPECT_EQ(g.stats.image_missing, e.stats.image_missing);
      EXPECT_EQ(g.stats.tracked, e.stats.tracked);
      EXPECT_EQ(g.stats.new_features, e.stats.new_features);
      EXPECT_EQ(g.stats.lost_lk, e.stats.lost_lk);
      EXPECT_EQ(g.stats.lost_forward_backward, e.stats.lost_forward_backward);
      EXPECT_EQ(g.stats.lost_anchor, e.stats.lost_anchor);
      EXPECT_EQ(g.stats.ransac_inliers, e.stats.ransac_inliers);
      EXPECT_EQ(g.stats.ransac_outliers, e.stats.ransac_outliers);
      EXPECT_TRUE(SameBits(g.stats.mean_track_length, e.stats.mean_track_length));
      EXPECT_TRUE(SameBits(g.stats.sfd, e.stats.sfd));
      EXPECT_EQ(g.stats.seconds_lk, 0.0);  // timings are not stored
      ASSERT_EQ(g.features.size(), e.features.size());
      for (size_t i = 0; i < e.features.size(); ++i) {
        EXPECT_EQ(g.features[i].id, e.features[i].id);
        EXPECT_TRUE(SameBits(g.features[i].pixel.x(), e.features[i].pixel.x()));
        EXPECT_TRUE(SameBits(g.features[i].pixel.y(), e.features[i].pixel.y()));
        EXPECT_TRUE(SameBits(g.features[i].score, e.features[i].score));
        EXPECT_EQ(g.features[i].track_length, e.features[i].track_length);
      }
      if (descriptor_size == 0 || e.features.empty()) {
        EXPECT_TRUE(g.descriptors.empty());
        continue;
      }
      ASSERT_EQ(g.descriptors.type(), e.descriptors.type());
      ASSERT_EQ(g.descriptors.size(), e.descriptors.size());
      EXPECT_EQ(std::memcmp(g.descriptors.data, e.descriptors.data,
                            e.descriptors.total() * e.descriptors.elemSize()),
                0);
    }
    ASSERT_EQ(got->cross_matches.size(), expected.cross_matches.size());
    for (size_t i = 0; i < expected.cross_matches.size(); ++i) {
      const CrossCameraMatch& e = expected.cross_matches[i];
      const CrossCameraMatch& g = got->cross_matches[i];
      EXPECT_EQ(g.camera_a, e.camera_a);
      EXPECT_EQ(g.id_a, e.id_a);
      EXPECT_EQ(g.camera_b, e.camera_b);
      EXPECT_TRUE(SameBits(g.pixel_b.x(), e.pixel_b.x()));
      EXPECT_TRUE(SameBits(g.pixel_b.y(), e.pixel_b.y()));
    }
    ASSERT_EQ(got->cross_pair_stats.size(), expected.cross_pair_stats.size());
    for (size_t i = 0; i < expected.cross_pair_stats.size(); ++i) {
      const CrossCameraPairStats& e = expected.cross_pair_stats[i];
      const CrossCameraPairStats& g = got->cross_pair_stats[i];
      EXPECT_EQ(
          std::tie(g.camera_a, g.camera_b, g.features, g.outside_view, g.lost_lk, g.lost_forward_backward,
                   g.lost_epipolar, g.lost_triangulation, g.over_limit, g.matches),
          std::tie(e.camera_a, e.camera_b, e.features, e.outside_view, e.lost_lk, e.lost_forward_backward,
                   e.lost_epipolar, e.lost_triangulation, e.over_limit, e.matches));
      EXPECT_EQ(g.seconds, 0.0);  // timings are not stored
    }
  }
  EXPECT_FALSE(reader.Next().has_value());
  EXPECT_FALSE(reader.Next().has_value());
}

TEST(TrackFile, RoundTripIsBitExact) {
  ExpectRoundTrip(0, 0);
  ExpectRoundTrip(64, CV_32F);
  ExpectRoundTrip(32, CV_8U);
}

TEST(TrackFile, WritingTwiceGivesTheSameBytes) {
  const fs::path a = TempFile("same_a.bin");
  const fs::path b = TempFile("same_b.bin");
  cv::setRNGSeed(5);
  WriteFrames(a, MakeHeader(8, CV_32F), MakeFrames(8, CV_32F));
  cv::setRNGSeed(5);
  WriteFrames(b, MakeHeader(8, CV_32F), MakeFrames(8, CV_32F));
  EXPECT_EQ(ReadFileToString(a), ReadFileToString(b));
}

TEST(TrackFile, UncommittedWriterLeavesNoFile) {
  const fs::path path = TempFile("uncommitted.bin");
  fs::remove(path);
  {
    TrackFileWriter writer(path, MakeHeader(0, 0));
    writer.Write(MakeFrames(0, 0)[0]);
  }
  EXPECT_FALSE(fs::exists(path));
  for (const auto& entry : fs::directory_iterator(path.parent_path())) {
    EXPECT_EQ(entry.path().filename().string().find("uncommitted.bin.tmp"), std::string::npos);
  }
}

// Reads the whole file; returns the InputError message ("" when none).
std::string ReadAllError(const fs::path& path) {
  try {
    TrackFileReader reader(path);
    while (reader.Next()) {
    }
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(TrackFile, TruncatedFileNamesFileAndByte) {
  const fs::path path = TempFile("full.bin");
  WriteFrames(path, MakeHeader(16, CV_32F), MakeFrames(16, CV_32F));
  const std::string bytes = ReadFileToString(path);
  const fs::path cut = TempFile("truncated.bin");
  // Every cut point fails with a message naming the file, never a crash.
  for (size_t size = 0; size < bytes.size(); size += 1 + size / 16) {
    WriteFileAtomic(cut, bytes.substr(0, size));
    const std::string message = ReadAllError(cut);
    ASSERT_FALSE(message.empty()) << "cut at " << size;
    EXPECT_EQ(message.rfind(cut.string() + ": ", 0), 0u) << message;
    if (size >= 12) {
      EXPECT_NE(message.find("truncated at byte " + std::to_string(size)), std::string::npos) << message;
    }
  }
  // Cut at the end record: all frames readable, then the missing end record is reported.
  WriteFileAtomic(cut, bytes.substr(0, bytes.size() - 8));
  EXPECT_NE(ReadAllError(cut).find("no end record"), std::string::npos);
  EXPECT_EQ(ReadAllError(path), "");
}

TEST(TrackFile, BadMagicAndTrailingBytes) {
  const fs::path path = TempFile("magic.bin");
  WriteFileAtomic(path, "PK\x03\x04 this is a zip, not a track file");
  const std::string message = ReadAllError(path);
  EXPECT_EQ(message.rfind(path.string() + ": not an mcvo track file", 0), 0u) << message;

  WriteFrames(path, MakeHeader(0, 0), MakeFrames(0, 0));
  WriteFileAtomic(path, ReadFileToString(path) + "x");
  EXPECT_NE(ReadAllError(path).find("unexpected bytes after the end record"), std::string::npos);

  const fs::path missing = TempFile("does_not_exist.bin");
  EXPECT_EQ(ReadAllError(missing), missing.string() + ": cannot open track file");
}

TEST(TrackFile, AbsurdFeatureCountIsReportedNotAllocated) {
  const fs::path path = TempFile("count.bin");
  WriteFrames(path, MakeHeader(0, 0), MakeFrames(0, 0));
  std::string bytes = ReadFileToString(path);
  // The first camera's feature count sits right after the header, the frame
  // head (12 bytes) and the camera stats (45 bytes).
  const size_t header_end = 12 + (static_cast<uint8_t>(bytes[8]) | static_cast<uint8_t>(bytes[9]) << 8);
  const size_t count_at = header_end + 12 + 45;
  ASSERT_EQ(static_cast<uint8_t>(bytes[count_at]), 3);
  bytes[count_at + 3] = '\x7f';
  WriteFileAtomic(path, bytes);
  EXPECT_NE(ReadAllError(path).find("announces"), std::string::npos) << ReadAllError(path);
}

// Byte offset where frame record `index` starts in a file written by
// WriteFrames(MakeHeader(0, 0), frames) (no descriptors).
size_t FrameOffset(const std::string& bytes, const std::vector<MultiCameraFrame>& frames, size_t index,
                   bool cross_camera_block = true) {
  size_t at = 12 + (static_cast<uint8_t>(bytes[8]) | static_cast<uint8_t>(bytes[9]) << 8);
  for (size_t f = 0; f < index; ++f) {
    at += 12;
    for (const CameraFrameResult& camera : frames[f].cameras) at += 49 + 24 * camera.features.size();
    if (cross_camera_block)
      at += 8 + 40 * frames[f].cross_pair_stats.size() + 18 * frames[f].cross_matches.size();
  }
  return at;
}

// The bytes of an older version of a file written by
// WriteFrames(MakeHeader(0, 0), frames): camera blocks without lost_anchor
// (versions 1 and 2), frames without the cross-camera block (version 1).
std::string OlderVersion(const std::string& v3, const std::vector<MultiCameraFrame>& frames, int version) {
  std::string out = v3.substr(0, FrameOffset(v3, frames, 0));
  const size_t version_at = out.find("\"format_version\":3");
  EXPECT_NE(version_at, std::string::npos);
  out[version_at + 17] = static_cast<char>('0' + version);
  for (size_t f = 0; f < frames.size(); ++f) {
    size_t at = FrameOffset(v3, frames, f);
    out += v3.substr(at, 12);  // frame index, time
    at += 12;
    for (const CameraFrameResult& camera : frames[f].cameras) {
      const size_t block = 49 + 24 * camera.features.size();
      out += v3.substr(at, 16);                // tracked, new, lost_lk, lost_forward_backward
      out += v3.substr(at + 20, block - 20);   // from ransac_inliers on: lost_anchor (bytes 16-19) left out
      at += block;
    }
    if (version >= 2) out += v3.substr(at, FrameOffset(v3, frames, f + 1) - at);
  }
  out += v3.substr(v3.size() - 8);  // end record
  return out;
}

TEST(TrackFile, ReadsVersions1And2) {
  const fs::path path = TempFile("older_versions.bin");
  const std::vector<MultiCameraFrame> frames = MakeFrames(0, 0);
  WriteFrames(path, MakeHeader(0, 0), frames);
  const std::string v3 = ReadFileToString(path);
  for (int version : {1, 2}) {
    SCOPED_TRACE(version);
    WriteFileAtomic(path, OlderVersion(v3, frames, version));
    TrackFileReader reader(path);
    EXPECT_EQ(reader.header().format_version, version);
    size_t count = 0;
    while (std::optional<MultiCameraFrame> frame = reader.Next()) {
      ASSERT_LT(count, frames.size());
      const MultiCameraFrame& expected = frames[count];
      EXPECT_EQ(frame->cameras[0].features.size(), expected.cameras[0].features.size());
      EXPECT_EQ(frame->cameras[1].stats.ransac_inliers, expected.cameras[1].stats.ransac_inliers);
      EXPECT_EQ(frame->cameras[1].stats.lost_forward_backward, expected.cameras[1].stats.lost_forward_backward);
      EXPECT_EQ(frame->cameras[1].stats.lost_anchor, 0);  // not recorded before version 3
      if (version == 1) {
        EXPECT_TRUE(frame->cross_matches.empty());
        EXPECT_TRUE(frame->cross_pair_stats.empty());
      } else {
        EXPECT_EQ(frame->cross_matches.size(), expected.cross_matches.size());
      }
      ++count;
    }
    EXPECT_EQ(count, frames.size());
  }

  // Versions this reader does not know are named.
  std::string v4 = v3;
  v4[v3.find("\"format_version\":3") + 17] = '4';
  WriteFileAtomic(path, v4);
  const std::string message = ReadAllError(path);
  EXPECT_NE(message.find("unsupported format_version 4 (this reader: 1 to 3)"), std::string::npos) << message;
  EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
}

TEST(TrackFile, CorruptCrossCameraBlockNamesTheByte) {
  const fs::path path = TempFile("cross.bin");
  const std::vector<MultiCameraFrame> frames = MakeFrames(0, 0);
  WriteFrames(path, MakeHeader(0, 0), frames);
  const std::string bytes = ReadFileToString(path);
  // Frame 0's cross-camera block: u32 pairs, one pair record, u32 matches, match records.
  const size_t block = FrameOffset(bytes, frames, 1) - 8 - 40 - 18 * frames[0].cross_matches.size();
  ASSERT_EQ(static_cast<uint8_t>(bytes[block]), 1);  // one pair

  std::string bad = bytes;
  bad[block + 4 + 4] = '\x05';  // camera_b = 5 of 2 cameras
  WriteFileAtomic(path, bad);
  std::string message = ReadAllError(path);
  EXPECT_NE(message.find("cross-camera pair 0-5"), std::string::npos) << message;
  EXPECT_NE(message.find("(at byte " + std::to_string(block + 4) + ")"), std::string::npos) << message;

  bad = bytes;
  const size_t second_match = block + 4 + 40 + 4 + 18;
  bad[second_match + 1] = bad[second_match - 18 + 1];  // the same id as the first match: not sorted
  WriteFileAtomic(path, bad);
  message = ReadAllError(path);
  EXPECT_NE(message.find("cross-camera match 1"), std::string::npos) << message;
  EXPECT_NE(message.find("(at byte " + std::to_string(second_match) + ")"), std::string::npos) << message;

  bad = bytes;
  bad[block + 4 + 40 + 3] = '\x7f';  // absurd match count
  WriteFileAtomic(path, bad);
  message = ReadAllError(path);
  EXPECT_NE(message.find("announces"), std::string::npos) << message;
  EXPECT_NE(message.find("cross-camera matches at byte " + std::to_string(block + 44)), std::string::npos)
      << message;
}

}  // namespace
}  // namespace mcvo
