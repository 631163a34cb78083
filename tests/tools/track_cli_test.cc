// `mcvo track` as a user runs it: a tiny synthetic sequence is tracked, the
// track file read back, the statistics checked, thread counts compared, and
// model errors reported at start-up.
#include <gtest/gtest.h>
#include <unistd.h>

#include <sys/wait.h>
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mcvo/frontend/track_file.h"
#include "mcvo/util/file.h"

namespace {

namespace fs = std::filesystem;

struct Result {
  int exit_code = -1;
  std::string output;
  double seconds = 0.0;
};

Result RunMcvo(const std::string& args) {
  const std::string command = std::string(MCVO_BINARY) + " " + args + " 2>&1";
  Result result;
  const auto start = std::chrono::steady_clock::now();
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe) != nullptr) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

// One folder per process: ctest runs each test of this binary as its own
// process, in parallel, and each renders its dataset here.
fs::path Root() {
  return fs::path(::testing::TempDir()) / ("mcvo_track_cli_test_" + std::to_string(::getpid()));
}

// A 4-frame stereo sequence, rendered once per process.
const fs::path& Dataset() {
  static const fs::path dir = [] {
    const fs::path seq = Root() / "seq";
    fs::remove_all(Root());
    fs::create_directories(Root());
    const Result r =
        RunMcvo("synth --preset stereo --frames 4 --image-scale 0.25 --samples 1 --out " + seq.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return seq;
  }();
  return dir;
}

TEST(TrackCli, TracksASequence) {
  const fs::path out = Root() / "tracks.bin";
  const fs::path stats = Root() / "stats.csv";
  const Result r = RunMcvo("track --dataset " + Dataset().string() + " --out " + out.string() + " --stats " +
                           stats.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;

  mcvo::TrackFileReader reader(out);
  EXPECT_EQ(reader.header().camera_names.size(), 2u);
  EXPECT_EQ(reader.header().detector, "shi_tomasi");
  EXPECT_EQ(reader.header().descriptor_size, 0);
  EXPECT_NE(reader.header().config_json.find("\"frontend\""), std::string::npos);
  EXPECT_EQ(reader.header().format_version, 3);
  int frames = 0;
  size_t features = 0;
  size_t cross_matches = 0;
  std::set<uint64_t> ids;
  while (std::optional<mcvo::MultiCameraFrame> frame = reader.Next()) {
    EXPECT_EQ(frame->frame_index, frames);
    ASSERT_EQ(frame->cameras.size(), 2u);
    // The stereo pair overlaps: camera 0's features are found in camera 1.
    ASSERT_EQ(frame->cross_pair_stats.size(), 1u);
    EXPECT_EQ(frame->cross_pair_stats[0].matches, static_cast<int>(frame->cross_matches.size()));
    cross_matches += frame->cross_matches.size();
    for (const mcvo::CameraFrameResult& camera : frame->cameras) {
      features += camera.features.size();
      for (const mcvo::TrackedFeature& f : camera.features) {
        EXPECT_NE(f.id, 0u);
        ids.insert(f.id);
      }
    }
    ++frames;
  }
  EXPECT_EQ(frames, 4);
  EXPECT_GT(features, 40u);
  EXPECT_LT(ids.size(), features);  // some features are tracked over frames
  EXPECT_GT(cross_matches, features / 2 / 4);

  const std::string csv = mcvo::ReadFileToString(stats);
  EXPECT_EQ(csv.rfind("frame,t_ns,camera,tracked,new,ransac_inliers,ransac_outliers,mean_track_length,sfd,"
                      "image_missing,cross_matches,lost_lk,lost_forward_backward,lost_anchor,untextured\n",
                      0),
            0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 4 * 2) << csv;
  // cross_matches: camera 0's features found in camera 1, summed over the
  // rows. Every feature of a camera's previous row is either tracked or
  // counted by one of the reasons it was lost.
  size_t csv_cross_matches = 0;
  std::map<std::string, long> previous_features;  // camera -> tracked + new of its last row
  size_t line_start = csv.find('\n') + 1;
  while (line_start < csv.size()) {
    const size_t line_end = csv.find('\n', line_start);
    std::vector<std::string> fields;
    std::stringstream line(csv.substr(line_start, line_end - line_start));
    for (std::string field; std::getline(line, field, ',');) fields.push_back(field);
    ASSERT_EQ(fields.size(), 15u) << line.str();
    const size_t value = std::stoul(fields[10]);
    if (fields[2] == "image_01") {
      EXPECT_EQ(value, 0u) << line.str();
    }
    csv_cross_matches += value;
    const long tracked = std::stol(fields[3]), added = std::stol(fields[4]);
    const long lost =  // ransac_outliers, lost_lk, lost_forward_backward, lost_anchor
        std::stol(fields[6]) + std::stol(fields[11]) + std::stol(fields[12]) + std::stol(fields[13]);
    const auto previous = previous_features.find(fields[2]);
    if (previous != previous_features.end() && fields[9] == "0") {
      EXPECT_EQ(tracked + lost, previous->second) << line.str();
    }
    previous_features[fields[2]] = tracked + added;
    line_start = line_end + 1;
  }
  EXPECT_EQ(csv_cross_matches, cross_matches);
}

TEST(TrackCli, IdenticalAtAnyThreadCount) {
  std::string tracks[2], stats[2];
  for (int threads = 1; threads <= 2; ++threads) {
    const fs::path out = Root() / ("threads" + std::to_string(threads) + ".bin");
    const fs::path csv = Root() / ("threads" + std::to_string(threads) + ".csv");
    const Result r =
        RunMcvo("track --dataset " + Dataset().string() + " --threads " + std::to_string(threads) +
                " --detector orb --out " + out.string() + " --stats " + csv.string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    tracks[threads - 1] = mcvo::ReadFileToString(out);
    stats[threads - 1] = mcvo::ReadFileToString(csv);
  }
  EXPECT_FALSE(tracks[0].empty());
  EXPECT_TRUE(tracks[0] == tracks[1]) << "track files differ between 1 and 2 threads";
  EXPECT_EQ(stats[0], stats[1]);
}

// --timing names every stage of issue 17's profile; decoding and CLAHE are
// timed on their own (CLAHE 0 when the config turns it off).
TEST(TrackCli, TimingNamesEveryStage) {
  const fs::path& dataset = Dataset();  // creates Root()
  const fs::path no_clahe = Root() / "no_clahe.json";
  mcvo::WriteFileAtomic(no_clahe, "{\"frontend\": {\"clahe\": {\"enabled\": false}}}\n");
  for (const bool clahe : {true, false}) {
    const fs::path timing = Root() / (clahe ? "timing_clahe.json" : "timing_plain.json");
    const Result r =
        RunMcvo("track --dataset " + dataset.string() + " --out " + (Root() / "timed.bin").string() +
                " --timing " + timing.string() + (clahe ? "" : " --config " + no_clahe.string()));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json json = nlohmann::json::parse(mcvo::ReadFileToString(timing));
    EXPECT_EQ(json.at("frames"), 4);
    const nlohmann::json& seconds = json.at("seconds_per_frame");
    for (const char* key : {"decode", "decode_wait", "clahe", "pyramid", "lk", "detection", "ransac",
                            "anchor", "selection", "cross_camera", "track_wall", "write", "total"}) {
      ASSERT_TRUE(seconds.contains(key)) << key;
      EXPECT_GE(seconds.at(key).get<double>(), 0.0) << key;
    }
    EXPECT_GT(seconds.at("decode").get<double>(), 0.0);
    EXPECT_GT(seconds.at("pyramid").get<double>(), 0.0);
    if (clahe) {
      EXPECT_GT(seconds.at("clahe").get<double>(), 0.0);
    } else {
      EXPECT_EQ(seconds.at("clahe").get<double>(), 0.0);
    }
    EXPECT_GE(seconds.at("total").get<double>(), seconds.at("track_wall").get<double>());
  }
}

TEST(TrackCli, MissingModelFailsAtStartUp) {
  const fs::path out = Root() / "never.bin";
  const Result r = RunMcvo("track --dataset " + Dataset().string() +
                           " --detector xfeat --model /nonexistent.onnx --out " + out.string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("/nonexistent.onnx"), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_EQ(r.output.find("[info]"), std::string::npos) << "tracking started: " << r.output;
  EXPECT_LT(r.seconds, 10.0);
  EXPECT_FALSE(fs::exists(out));
}

TEST(TrackCli, MisuseGivesExitCode2) {
  const std::string base = "track --dataset " + Dataset().string() + " --out " + (Root() / "x.bin").string();
  EXPECT_EQ(RunMcvo("track --out x.bin").exit_code, 2);  // no --dataset
  EXPECT_EQ(RunMcvo(base + " --detector sift").exit_code, 2);
  EXPECT_EQ(RunMcvo(base + " --selection random").exit_code, 2);
  EXPECT_EQ(RunMcvo(base + " --threads -1").exit_code, 2);
  EXPECT_EQ(RunMcvo(base + " --detector xfeat").exit_code, 2);  // no model
  EXPECT_EQ(RunMcvo("track --dataset " + (Root() / "nosuch").string() + " --out x.bin").exit_code, 3);
}

TEST(TrackCli, XFeatModelTracks) {
  const fs::path model = fs::path(MCVO_SHARED_DIR) / "models" / "xfeat_480x640.onnx";
  if (!fs::exists(model)) GTEST_SKIP() << "no model at " << model;
  const fs::path out = Root() / "xfeat.bin";
  const Result r = RunMcvo("track --dataset " + Dataset().string() + " --detector xfeat --model " +
                           model.string() + " --frames 2 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  mcvo::TrackFileReader reader(out);
  EXPECT_EQ(reader.header().detector, "xfeat");
  EXPECT_GT(reader.header().descriptor_size, 0);
  int frames = 0;
  while (std::optional<mcvo::MultiCameraFrame> frame = reader.Next()) {
    for (const mcvo::CameraFrameResult& camera : frame->cameras) {
      EXPECT_FALSE(camera.features.empty());
      EXPECT_EQ(camera.descriptors.rows, static_cast<int>(camera.features.size()));
    }
    ++frames;
  }
  EXPECT_EQ(frames, 2);
}

}  // namespace
