// The upper bounds of the config's integer keys (at the bound a config loads,
// one above it fails naming the key) and the bounds checked against the rig.
#include "mcvo/config/option_bounds.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mcvo/config/config.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

// The documented maxima (docs/config.md), written out here so that a changed
// bound fails this test until the docs and this table follow.
const std::map<std::string, int64_t>& DocumentedMaxima() {
  static const std::map<std::string, int64_t> maxima = {
      {"/frontend/max_features_pinhole", 20000},
      {"/frontend/max_features_fisheye", 20000},
      {"/frontend/min_distance_px", 1000},
      {"/frontend/candidate_factor", 100},
      {"/frontend/clahe/tile_grid", 256},
      {"/frontend/lk/window_px", 255},
      {"/frontend/lk/pyramid_levels", 10},
      {"/frontend/lk/predict_motion_min_points", 10000},
      {"/frontend/lk/max_iterations", 1000},
      {"/frontend/anchor/half_size_px", 127},
      {"/frontend/anchor/max_iterations", 1000},
      {"/frontend/superpoint/downscale", 16},
      {"/frontend/superpoint/nms_radius_px", 64},
      {"/frontend/superpoint/border_px", 1000},
      {"/frontend/cross_camera/max_matches_per_pair", 100000},
      {"/frontend/cross_camera/rematch_every", 1000000},
      {"/initializer/window_size", 200},
      {"/initializer/min_correspondences", 100000},
      {"/initializer/min_cameras_passing", 1000},
      {"/initializer/relax_required_after_windows", 1000000},
      {"/initializer/min_cross_camera_matches", 100000},
      {"/initializer/max_skipped_windows", 1000000},
      {"/initializer/max_rig_ba_iterations", 1000},
      {"/initializer/sfm/ransac_max_iterations", 10000},
      {"/initializer/sfm/min_correspondences", 100000},
      {"/initializer/sfm/min_inliers", 100000},
      {"/initializer/sfm/min_points_for_pnp", 100000},
      {"/initializer/sfm/max_ba_iterations", 1000},
      {"/initializer/consistency/min_landmarks", 100000},
      {"/initializer/overlap_start/after_failed_windows", 1000000},
      {"/initializer/overlap_start/min_points", 100000},
      {"/initializer/overlap_start/min_frame_inliers", 100000},
      {"/backend/window_size", 200},
      {"/backend/max_iterations", 1000},
      {"/backend/min_observations", 1000},
      {"/backend/keyframe_min_tracked", 100000},
      {"/backend/min_pnp_inliers", 100000},
      {"/backend/scale_correction_period", 1000000},
      {"/backend/reverse_pass_overlap_frames", 10000},
      {"/loop/relocalise_map_keyframes", 1000},
      {"/loop/relocalise_query_keyframes", 1000},
      {"/loop/frontend_cache_mb", 65536},
      {"/loop/features_per_camera", 20000},
      {"/loop/exclude_recent_keyframes", 1000000},
      {"/loop/max_candidates", 100},
      {"/loop/landmark_levels", 8},
      {"/loop/max_match_distance", 256},
      {"/loop/pnp_max_iterations", 10000},
      {"/loop/min_inliers", 100000},
      {"/loop/min_camera_inliers", 100000},
      {"/loop/consistency_window", 1000},
      {"/loop/candidate_neighbours", 1000},
      {"/loop/cross_camera/window_keyframes", 1000},
      {"/loop/cross_camera/max_distance", 256},
      {"/loop/pose_graph/loop_loss_stages", 100},
      {"/loop/pose_graph/max_iterations", 10000},
      {"/refine/max_iterations", 1000},
      {"/refine/outlier_rounds", 100},
      {"/refine/min_observations", 1000},
      {"/refine/thin_tracks_longer_than", 1000000},
      {"/refine/thin_track_stride", 1000000},
      {"/refine/straight_window_keyframes", 10000},
      {"/refine/straight_overlap_min_landmarks", 1000000},
      {"/colmap/fit_grid", 1024},
      {"/colmap/min_track_length", 1000000},
      {"/runtime/threads", 1024},
      {"/eval/align_num_poses", 100000000},
      {"/eval/local_scale_window", 1000000},
  };
  return maxima;
}

std::string ErrorOf(const nlohmann::json& config) {
  try {
    ParsePipelineOptions(config.dump(), "c.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

// The config setting one key; keys whose value must stay below another's
// (initializer.window_size <= backend.window_size) set that one too.
nlohmann::json ConfigWith(const std::string& pointer, int64_t value) {
  nlohmann::json config = nlohmann::json::object();
  config[nlohmann::json::json_pointer(pointer)] = value;
  if (pointer == "/initializer/window_size") config["backend"]["window_size"] = value;
  return config;
}

// Every integer leaf of a JSON tree, by its pointer.
void IntegerKeys(const nlohmann::json& j, const std::string& path, std::vector<std::string>* keys) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) IntegerKeys(it.value(), path + "/" + it.key(), keys);
  } else if (j.is_number_integer()) {
    keys->push_back(path);
  }
}

TEST(OptionBounds, EveryIntegerKeyButTheSeedHasOneBound) {
  std::vector<std::string> keys;
  IntegerKeys(nlohmann::json::parse(PipelineOptionsToJson(PipelineOptions())), "", &keys);
  std::map<std::string, int> bounded;
  for (const OptionBound& bound : OptionBounds(PipelineOptions())) ++bounded[bound.pointer];
  for (const std::string& key : keys) {
    if (key == "/runtime/seed") continue;
    EXPECT_EQ(bounded[key], 1) << key;
  }
  EXPECT_EQ(bounded.size() + 1, keys.size());  // no bound of a key the config lacks
  std::map<std::string, int64_t> maxima;
  for (const OptionBound& bound : OptionBounds(PipelineOptions())) maxima[bound.pointer] = bound.max;
  EXPECT_EQ(maxima, DocumentedMaxima());
}

TEST(OptionBounds, AtTheBoundLoadsAndAboveFailsNamingTheKey) {
  for (const auto& [pointer, max] : DocumentedMaxima()) {
    SCOPED_TRACE(pointer);
    EXPECT_EQ(ErrorOf(ConfigWith(pointer, max)), "(no error)");
    const std::string error = ErrorOf(ConfigWith(pointer, max + 1));
    EXPECT_EQ(error.rfind("c.json: " + pointer + ": ", 0), 0u) << error;
    EXPECT_NE(error.find(std::to_string(max)), std::string::npos) << error;
  }
}

TEST(OptionBounds, TheIssuesValuesFailWithOneLine) {
  EXPECT_EQ(ErrorOf(ConfigWith("/frontend/lk/window_px", 100001)),
            "c.json: /frontend/lk/window_px: 100001 is above the maximum 255");
  EXPECT_EQ(ErrorOf(ConfigWith("/frontend/lk/window_px", 1001)),
            "c.json: /frontend/lk/window_px: 1001 is above the maximum 255");
  EXPECT_EQ(ErrorOf(ConfigWith("/frontend/clahe/tile_grid", 100000)),
            "c.json: /frontend/clahe/tile_grid: 100000 is above the maximum 256");
  EXPECT_EQ(ErrorOf(ConfigWith("/frontend/anchor/half_size_px", 100000)),
            "c.json: /frontend/anchor/half_size_px: 100000 is above the maximum 127");
  EXPECT_EQ(ErrorOf(ConfigWith("/backend/window_size", 2000000000)),
            "c.json: /backend/window_size: 2000000000 is above the maximum 200");
  EXPECT_EQ(ErrorOf(ConfigWith("/loop/features_per_camera", 1000000000)),
            "c.json: /loop/features_per_camera: 1000000000 is above the maximum 20000");
}

// Each maximum is written beside its key in docs/config.md: on a table row of
// the key (named from its section, e.g. `lk.window_px` under "## frontend",
// `window_keyframes` under "### loop.cross_camera") as "max N".
TEST(OptionBounds, DocsGiveEachMaximum) {
  std::istringstream docs(ReadFileToString(std::filesystem::path(MCVO_SOURCE_DIR) / "docs" / "config.md"));
  std::map<std::string, std::string> rows;  // "/section/key" -> the row
  std::string section;
  for (std::string line; std::getline(docs, line);) {
    std::smatch m;
    if (std::regex_match(line, m, std::regex("#+ (\\w+(\\.\\w+)*)\\s*"))) {
      section = "/" + std::regex_replace(m[1].str(), std::regex("\\."), "/");
    } else if (std::regex_search(line, m, std::regex("^\\| `([\\w.]+)` \\|"))) {
      rows[section + "/" + std::regex_replace(m[1].str(), std::regex("\\."), "/")] = line;
    }
  }
  for (const auto& [pointer, max] : DocumentedMaxima()) {
    const auto it = rows.find(pointer);
    ASSERT_NE(it, rows.end()) << pointer << " has no row in docs/config.md";
    EXPECT_TRUE(std::regex_search(it->second, std::regex("max " + std::to_string(max) + "\\b")))
        << pointer << ": " << it->second;
  }
}

Rig OneCameraRig(int width, int height) {
  Camera camera;
  camera.name = "cam0";
  camera.params = {100.0, 100.0, width / 2.0, height / 2.0};
  camera.width = width;
  camera.height = height;
  Rig rig;
  rig.cameras = {camera};
  return rig;
}

std::string RigErrorOf(const PipelineOptions& options, const Rig& rig) {
  try {
    CheckOptionsAgainstRig(options, rig, "c.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

PipelineOptions Unscaled() {
  PipelineOptions options;
  options.frontend.pixel_scale_reference_px = 0.0;  // the values as given on any camera
  return options;
}

TEST(CheckOptionsAgainstRig, LkWindowBelowTheImage) {
  const Rig rig = OneCameraRig(64, 48);
  PipelineOptions options = Unscaled();
  options.frontend.lk.window_px = 47;
  EXPECT_EQ(RigErrorOf(options, rig), "(no error)");
  options.frontend.lk.window_px = 48;
  EXPECT_EQ(RigErrorOf(options, rig),
            "c.json: /frontend/lk/window_px: 48 is not smaller than the smaller side of the image of camera "
            "cam0 (64 x 48 px)");
}

TEST(CheckOptionsAgainstRig, ClaheGridAtMostTheImageWhenEnabled) {
  const Rig rig = OneCameraRig(40, 60);
  PipelineOptions options = Unscaled();
  options.frontend.clahe.tile_grid = 40;
  EXPECT_EQ(RigErrorOf(options, rig), "(no error)");
  options.frontend.clahe.tile_grid = 41;
  const std::string error = RigErrorOf(options, rig);
  EXPECT_EQ(error.rfind("c.json: /frontend/clahe/tile_grid: 41 tiles", 0), 0u) << error;
  EXPECT_NE(error.find("camera cam0 (40 x 60 px)"), std::string::npos) << error;
  options.frontend.clahe.enabled = false;
  EXPECT_EQ(RigErrorOf(options, rig), "(no error)");
}

TEST(CheckOptionsAgainstRig, AnchorTemplateAtMostTheImageWhenEnabled) {
  const Rig rig = OneCameraRig(64, 48);
  PipelineOptions options = Unscaled();
  options.frontend.anchor.half_size_px = 23;  // 47 px
  EXPECT_EQ(RigErrorOf(options, rig), "(no error)");
  options.frontend.anchor.half_size_px = 24;  // 49 px
  const std::string error = RigErrorOf(options, rig);
  EXPECT_EQ(error.rfind("c.json: /frontend/anchor/half_size_px: 24 gives", 0), 0u) << error;
  EXPECT_NE(error.find("camera cam0 (64 x 48 px)"), std::string::npos) << error;
  options.frontend.anchor.enabled = false;
  EXPECT_EQ(RigErrorOf(options, rig), "(no error)");
}

TEST(CheckOptionsAgainstRig, ChecksTheScaledValuesOfASmallCamera) {
  // 100 x 25: sqrt = 50, a fifth of the reference 250: a 101 px window
  // becomes 2 floor(101 / 5 / 2) + 1 = 21 px on it, the image's smaller side 25.
  Rig rig = OneCameraRig(100, 25);
  PipelineOptions options;
  options.frontend.lk.window_px = 101;
  EXPECT_EQ(RigErrorOf(options, rig), "(no error)");
  options.frontend.lk.window_px = 131;  // 2 floor(13.1) + 1 = 27 px
  const std::string error = RigErrorOf(options, rig);
  EXPECT_EQ(error.rfind("c.json: /frontend/lk/window_px: 131 (27 on this camera, scaled) is not smaller", 0), 0u)
      << error;
  // The second camera of a rig is checked too.
  rig = OneCameraRig(640, 480);
  rig.cameras.push_back(OneCameraRig(100, 25).cameras[0]);
  rig.cameras[1].name = "small";
  EXPECT_NE(RigErrorOf(options, rig).find("camera small (100 x 25 px)"), std::string::npos);
}

TEST(CheckOptionsAgainstRig, DefaultsPassOnTinyImages) {
  EXPECT_EQ(RigErrorOf(PipelineOptions(), OneCameraRig(141, 38)), "(no error)");
  EXPECT_EQ(RigErrorOf(PipelineOptions(), OneCameraRig(3840, 2160)), "(no error)");
}

}  // namespace
}  // namespace mcvo
