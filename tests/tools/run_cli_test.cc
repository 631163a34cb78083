// `mcvo run` as a user runs it, on a short synthetic sequence of the
// KITTI-360 rig (4 cameras: a stereo pair and two MEI fisheyes) with one
// fisheye blacked out for 10 frames: the run completes in one segment, is
// accurate, writes every documented output, gives byte-identical outputs at
// 1 and 2 threads and when replayed from a track file, and fails cleanly on
// bad input.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "mcvo/io/trajectory_io.h"
#include "mcvo/util/file.h"
#include "tools/fixture_cache.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::RunMcvo;

// This process's scratch folder, emptied on first use.
fs::path Root() {
  static const fs::path dir = mcvo::test::ProcessScratch("mcvo_run_cli_test");
  return dir;
}

constexpr int kFrames = 60;

// Rendered once per build and shared by the tests of this file (each its
// own process): tests/tools/fixture_cache.h. Read only.
const fs::path& Dataset() {
  static const fs::path dir = [] {
    std::string error;
    const fs::path seq =
        mcvo::test::CachedSynth("--preset kitti360 --frames " + std::to_string(kFrames) +
                                    " --image-scale 0.35 --samples 1 --blackout image_03:20:10",
                                &error);
    EXPECT_FALSE(seq.empty()) << error;
    return seq;
  }();
  return dir;
}

std::string Config() { return Quote(std::string(MCVO_SOURCE_DIR) + "/config/kitti360_4cam.json"); }

nlohmann::json ReadJson(const fs::path& path) { return nlohmann::json::parse(mcvo::ReadFileToString(path)); }

// Column `name` of a CSV file, one string per data row.
std::vector<std::string> CsvColumn(const fs::path& path, const std::string& name) {
  std::istringstream in(mcvo::ReadFileToString(path));
  std::string line;
  std::getline(in, line);
  int column = -1, k = 0;
  std::istringstream header(line);
  for (std::string field; std::getline(header, field, ','); ++k) {
    if (field == name) column = k;
  }
  std::vector<std::string> out;
  if (column < 0) return out;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    std::string field;
    for (int i = 0; i <= column && std::getline(row, field, ','); ++i) {
    }
    out.push_back(field);
  }
  return out;
}

TEST(RunCli, CompletesAccuratelyAndIsDeterministic) {
  const fs::path out1 = Root() / "run_t1", out2 = Root() / "run_t2", replay = Root() / "replay";
  auto r = RunMcvo("run --dataset " + Quote(Dataset().string()) + " --config " + Config() +
                   " --threads 1 --out " + Quote(out1.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunMcvo("run --dataset " + Quote(Dataset().string()) + " --config " + Config() + " --threads 2 --out " +
              Quote(out2.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;

  for (const char* file :
       {"trajectory.tum", "trajectory_kitti.txt", "trajectory_euroc.csv", "keyframes.tum", "scale_log.csv",
        "frame_stats.csv", "timing.csv", "run.json", "eval/eval.json", "report.html", "report.md",
        "colmap/sparse/0/points3D.bin", "colmap/sparse_txt/0/points3D.txt"}) {
    EXPECT_TRUE(fs::is_regular_file(out1 / file)) << file;
  }
  EXPECT_FALSE(fs::exists(Root() / ("run_t1.tmp-" + std::to_string(::getpid()))));

  // Identical at 1 and 2 threads: run.json lists every output's SHA-256.
  const nlohmann::json run1 = ReadJson(out1 / "run.json"), run2 = ReadJson(out2 / "run.json");
  nlohmann::json hashes1 = run1["outputs_sha256"], hashes2 = run2["outputs_sha256"];
  ASSERT_TRUE(hashes1.contains("trajectory.tum"));
  hashes1.erase("timing.csv");
  hashes2.erase("timing.csv");
  EXPECT_EQ(hashes1, hashes2);
  EXPECT_EQ(run1["config"], run2["config"]);
  EXPECT_EQ(run1["inputs"], run2["inputs"]);
  EXPECT_TRUE(hashes1.contains("colmap/sparse/0/points3D.bin"));
  EXPECT_TRUE(hashes1.contains("report.html"));

  // The global bundle adjustment ran (its output is in the hashes above,
  // so it too is identical at 1 and 2 threads), fitting the observations
  // better than the odometry did; the odometry's trajectory stays beside it.
  const nlohmann::json& ba = run1["result"]["global_ba"];
  std::printf("global BA: %d keyframes, %d landmarks, %d observations, rms %.3f -> %.3f px, ATE before %.3f m\n",
              ba["keyframes"].get<int>(), ba["landmarks"].get<int>(), ba["observations"].get<int>(),
              ba["rms_error_px_before"].get<double>(), ba["rms_error_px_after"].get<double>(),
              ba["ate_rmse_m_before"].get<double>());
  EXPECT_TRUE(ba["applied"].get<bool>());
  EXPECT_EQ(ba["keyframes"].get<int>(), run1["result"]["keyframes"].get<int>());
  EXPECT_LT(ba["rms_error_px_after"].get<double>(), ba["rms_error_px_before"].get<double>());
  EXPECT_LT(ba["final_cost"].get<double>(), ba["initial_cost"].get<double>());
  EXPECT_TRUE(hashes1.contains("trajectory_vo.tum"));
  EXPECT_TRUE(hashes1.contains("eval_vo/eval.json"));
  // The local scale (50-frame windows) of the final trajectory and of the
  // one the BA started from: metric within 1.5 % on this fixture (0.28 % when written).
  const nlohmann::json& result = run1["result"];
  std::printf("local scale worst: %.3f %% (before the global BA %.3f %%)\n",
              result["local_scale_worst_percent"].get<double>(),
              ba["local_scale_worst_percent_before"].get<double>());
  EXPECT_EQ(result["local_scale_window_frames"].get<int>(), 50);
  EXPECT_LT(result["local_scale_worst_percent"].get<double>(), 1.5);
  EXPECT_GE(ba["local_scale_worst_percent_before"].get<double>(), 0.0);

  // The COLMAP model of the keyframes and landmarks: a real map, observations
  // that fit it (the map keeps those within 2x the back end's outlier
  // threshold of the final landmarks: about 2 px here), images linked.
  const nlohmann::json& colmap = run1["colmap"];
  std::printf("colmap: %d images, %d points, %d observations, mean error %.3f px\n",
              colmap["images"].get<int>(), colmap["points"].get<int>(), colmap["observations"].get<int>(),
              colmap["mean_reprojection_error_px"].get<double>());
  EXPECT_GT(colmap["points"].get<int>(), 300);
  EXPECT_GT(colmap["mean_track_length"].get<double>(), 3.0);
  EXPECT_LT(colmap["mean_reprojection_error_px"].get<double>(), 1.0);
  EXPECT_EQ(run1["result"]["sparse_map_keyframes"].get<int>(), run1["result"]["keyframes"].get<int>());
  int links = 0;
  for (const auto& entry : fs::recursive_directory_iterator(out1 / "colmap" / "images")) {
    links += entry.is_symlink() && fs::is_regular_file(entry.path()) ? 1 : 0;
  }
  EXPECT_EQ(links, colmap["images"].get<int>());

  // The blacked-out fisheye does not break tracking: one segment, every
  // frame after initialisation posed.
  const auto segments = CsvColumn(out1 / "frame_stats.csv", "segment");
  const auto has_pose = CsvColumn(out1 / "frame_stats.csv", "has_pose");
  ASSERT_EQ(static_cast<int>(segments.size()), kFrames);
  int first_posed = -1;
  for (int f = 0; f < kFrames; ++f) {
    EXPECT_EQ(segments[f], "0") << f;
    if (has_pose[f] == "1" && first_posed < 0) first_posed = f;
    if (first_posed >= 0) {
      EXPECT_EQ(has_pose[f], "1") << f;
    }
  }
  EXPECT_GE(first_posed, 0);
  EXPECT_LE(first_posed, 20);  // the stereo pair gives the scale on the straight start

  // Accuracy (SE3 alignment, no scale fitted), with bounds loose enough for
  // a 50 m run yet tight enough to catch a broken pipeline (a wrong scale or
  // a lost track gives metres).
  const nlohmann::json eval = ReadJson(out1 / "eval" / "eval.json");
  const double ate = eval["ate"]["translation_m"]["rmse"].get<double>();
  const double path = eval["rpe"]["gt_path_length_m"].get<double>();
  const double scale_error = eval["scale"]["scale_error_percent"].get<double>();
  std::printf("ATE %.3f m over %.1f m, scale error %.2f %%\n", ate, path, scale_error);
  EXPECT_GT(path, 30.0);
  EXPECT_LT(ate, 0.01 * path);
  EXPECT_LT(scale_error, 3.0);
  int init = 0;
  for (const auto& event : CsvColumn(out1 / "scale_log.csv", "event")) init += event == "init" ? 1 : 0;
  EXPECT_EQ(init, 1);

  // Replay from a track file: the same trajectory, byte for byte.
  const fs::path tracks = Root() / "tracks.bin";
  r = RunMcvo("track --dataset " + Quote(Dataset().string()) + " --config " + Config() + " --out " +
              Quote(tracks.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunMcvo("run --dataset " + Quote(Dataset().string()) + " --config " + Config() + " --tracks " +
              Quote(tracks.string()) + " --out " + Quote(replay.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(mcvo::ReadFileToString(replay / "trajectory.tum"),
            mcvo::ReadFileToString(out1 / "trajectory.tum"));
  EXPECT_EQ(mcvo::ReadFileToString(replay / "scale_log.csv"), mcvo::ReadFileToString(out1 / "scale_log.csv"));
  // Loop closure described the live run's keyframes from the frontend's
  // decode (pipeline/loop_image_cache.h), the replay's from their files:
  // the same loops, links and COLMAP model (points and their colours).
  EXPECT_GT(run1["timing"]["loop_keyframes_from_frontend_decode"].get<int>(), 0);
  EXPECT_EQ(ReadJson(replay / "run.json")["timing"]["loop_keyframes_from_frontend_decode"].get<int>(), 0);
  for (const char* file : {"loops.csv", "cross_camera_links.csv", "colmap/sparse_txt/0/points3D.txt",
                           "colmap/sparse_txt/0/images.txt"}) {
    EXPECT_EQ(mcvo::ReadFileToString(replay / file), mcvo::ReadFileToString(out1 / file)) << file;
  }

  // The frontend's stage profile in run.json's timing (as `mcvo track
  // --timing`) when images were tracked; a replay has no frontend stages.
  const nlohmann::json& stages = run1["timing"]["frontend_stages_s"];
  for (const char* stage : {"decode", "decode_wait", "clahe", "pyramid", "lk", "detection", "ransac", "anchor",
                            "selection", "cross_camera", "track_wall"}) {
    ASSERT_TRUE(stages.contains(stage)) << stage;
    EXPECT_GE(stages[stage].get<double>(), 0.0) << stage;
  }
  EXPECT_GT(stages["decode"].get<double>(), 0.0);
  EXPECT_GT(stages["detection"].get<double>(), 0.0);
  EXPECT_FALSE(ReadJson(replay / "run.json")["timing"].contains("frontend_stages_s"));
}

// loop.frontend_cache_mb bounds what the loop stage keeps from the
// frontend's decode (pipeline/loop_image_cache.h); with 0 every keyframe is
// read from its files again, and the outputs are the same.
TEST(RunCli, TheLoopCacheBudgetChangesOnlyWhereKeyframesAreReadFrom) {
  nlohmann::json config = nlohmann::json::parse(mcvo::ReadFileToString(MCVO_SOURCE_DIR "/config/kitti360_4cam.json"));
  const fs::path none = Root() / "budget_none", full = Root() / "budget_full";
  const fs::path config_none = Root() / "budget_none.json", config_full = Root() / "budget_full.json";
  config["loop"]["frontend_cache_mb"] = 0;
  mcvo::WriteFileAtomic(config_none, config.dump());
  config["loop"]["frontend_cache_mb"] = 1024;
  mcvo::WriteFileAtomic(config_full, config.dump());
  for (const auto& [out, cfg] : {std::pair{none, config_none}, std::pair{full, config_full}}) {
    const auto r = RunMcvo("run --dataset " + Quote(Dataset().string()) + " --frames 40 --config " +
                           Quote(cfg.string()) + " --force --out " + Quote(out.string()));
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  EXPECT_EQ(ReadJson(none / "run.json")["timing"]["loop_keyframes_from_frontend_decode"].get<int>(), 0);
  EXPECT_GT(ReadJson(full / "run.json")["timing"]["loop_keyframes_from_frontend_decode"].get<int>(), 0);
  for (const char* file : {"trajectory.tum", "scale_log.csv", "loops.csv", "cross_camera_links.csv",
                           "colmap/sparse_txt/0/points3D.txt", "colmap/sparse_txt/0/images.txt"}) {
    EXPECT_EQ(mcvo::ReadFileToString(none / file), mcvo::ReadFileToString(full / file)) << file;
  }
}

TEST(RunCli, BadInputFailsCleanlyWithoutOutput) {
  const fs::path& dataset = Dataset();
  const fs::path out = Root() / "bad";
  // A dataset that is not there: exit 3, the path named, no output folder.
  auto r = RunMcvo("run --dataset " + Quote((Root() / "nothing").string()) + " --out " + Quote(out.string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("nothing"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
  // A config with an unknown key: exit 3, file and key named.
  const fs::path config = Root() / "bad_config.json";
  mcvo::WriteFileAtomic(config, "{\"backend\": {\"window_sise\": 10}}");
  r = RunMcvo("run --dataset " + Quote(dataset.string()) + " --config " + Quote(config.string()) + " --out " +
              Quote(out.string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("window_sise"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
  // A track file that is not a track file.
  const fs::path tracks = Root() / "not_tracks.bin";
  mcvo::WriteFileAtomic(tracks, "garbage");
  r = RunMcvo("run --dataset " + Quote(dataset.string()) + " --tracks " + Quote(tracks.string()) + " --out " +
              Quote(out.string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("not_tracks.bin"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
  // A non-empty output folder is not replaced without --force.
  fs::create_directories(out);
  mcvo::WriteFileAtomic(out / "keep.txt", "x");
  r = RunMcvo("run --dataset " + Quote(dataset.string()) + " --frames 2 --out " + Quote(out.string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(fs::exists(out / "keep.txt"));
}

TEST(RunCli, ARunThatPosesNothingSaysWhyAndExitsWithFive) {
  // Too few frames to fill the initializer's window. (One camera poses at an
  // arbitrary scale: monocular_cli_test.cc; a rig that never moves:
  // standing_cli_test.cc.)
  const fs::path out = Root() / "short";
  auto r = RunMcvo("run --dataset " + Quote(Dataset().string()) + " --frames 5 --config " + Config() +
                   " --out " + Quote(out.string()));
  EXPECT_EQ(r.exit_code, 5) << r.output;
  EXPECT_NE(r.output.find("no frame posed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("too few frames to initialise"), std::string::npos) << r.output;
  // The outputs are written: the diagnostics are the point.
  ASSERT_TRUE(fs::exists(out / "run.json")) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  EXPECT_EQ(run["result"]["posed_frames"], 0);
  EXPECT_EQ(run["result"]["scale"], "metric");
  EXPECT_NE(run["result"]["warning"].get<std::string>().find("too few frames"), std::string::npos);
  const std::vector<std::string> sources = CsvColumn(out / "frame_stats.csv", "pose_source");
  EXPECT_EQ(sources.size(), 5u);
  for (const std::string& source : sources) EXPECT_EQ(source, "none");
}

TEST(RunCli, AfterEveryCameraIsBlackedOutForTenFramesTheRunGoesOnInTheSameWorld) {
  // 20 frames/s on a straight street (0.5 m a frame): every camera black for
  // frames 50-59 (5.5 m). Tracking is lost at frame 50; the next segment
  // initialises when the images return, the constant-velocity link places
  // it, and relocalisation against the map of the segment before verifies
  // (by re-tracking the map's landmarks from the link's prediction: the
  // BoW/ORB look finds 18 of the 40 inliers it needs here) and moves it
  // there. The whole trajectory is one: ATE over both segments with one SE3
  // alignment. Identical at 1 and 2 threads.
  std::string error;
  const fs::path seq = mcvo::test::CachedSynth(
      "--preset kitti360 --frames 100 --rate 20 --image-scale 0.35 --samples 1 --noise 1 --seed 5 "
      "--blackout all:50:10",
      &error);
  ASSERT_FALSE(seq.empty()) << error;
  const fs::path out = Root() / "blackout_all_run", out1 = Root() / "blackout_all_run_t1";
  auto r = RunMcvo("run --dataset " + Quote(seq.string()) + " --config " + Config() + " --threads 2 --out " +
                   Quote(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunMcvo("run --dataset " + Quote(seq.string()) + " --config " + Config() + " --threads 1 --out " +
              Quote(out1.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  nlohmann::json h2 = run["outputs_sha256"], h1 = ReadJson(out1 / "run.json")["outputs_sha256"];
  h1.erase("timing.csv");
  h2.erase("timing.csv");
  EXPECT_EQ(h1, h2);
  const nlohmann::json& result = run["result"];
  EXPECT_EQ(result["segments"], 2);
  EXPECT_EQ(result["segments_relocalised"], 1);
  // Every frame with images posed, none of the black ones.
  const std::vector<std::string> frame = CsvColumn(out / "frame_stats.csv", "frame");
  const std::vector<std::string> has_pose = CsvColumn(out / "frame_stats.csv", "has_pose");
  ASSERT_EQ(frame.size(), 100u);
  for (size_t k = 0; k < frame.size(); ++k) {
    EXPECT_EQ(has_pose[k], k >= 50 && k < 60 ? "0" : "1") << "frame " << frame[k];
  }
  const std::vector<std::string> events = CsvColumn(out / "scale_log.csv", "event");
  EXPECT_EQ(std::count(events.begin(), events.end(), "lost"), 1);
  EXPECT_EQ(std::count(events.begin(), events.end(), "link"), 1);
  EXPECT_EQ(std::count(events.begin(), events.end(), "relocalise"), 1);
  // 36.6 m of path; measured 0.064 % and 0.15 % (the constant-velocity link
  // alone: 0.30 % and 0.83 %, the segment 0.25 m off).
  EXPECT_LT(result["ate_percent_of_path"].get<double>(), 0.2);
  EXPECT_LT(result["scale_error_percent"].get<double>(), 0.5);
}

}  // namespace
