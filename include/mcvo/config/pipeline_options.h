// The pipeline options tree: one struct per component, defaults in code, a
// Check() that throws InputError naming the bad field by its JSON path in the
// config file ("/frontend/max_features_pinhole: must be > 0, got -3").
//
// A component that exists owns its options struct (eval: EvalOptions in
// eval/evaluate.h); the structs of components still to be built live here
// and move next to their component when it lands, so that this header then
// only composes them. JSON parsing and writing is in config/config.h, the
// only place that knows config JSON; the config module sits above the
// components so that it can read every component's own struct. Every key, its default and
// its meaning: docs/config.md. Defaults follow the published implementation
// (../shared/reference/mcvo-reference-notes.md) unless said otherwise.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "mcvo/eval/evaluate.h"
#include "mcvo/frontend/frontend_options.h"
#include "mcvo/util/enum_names.h"

namespace mcvo {

enum class LossType { kHuber, kCauchy, kTrivial };
inline constexpr EnumName<LossType> kLossTypeNames[] = {
    {LossType::kHuber, "huber"}, {LossType::kCauchy, "cauchy"}, {LossType::kTrivial, "none"}};

enum class SolverType { kDogleg, kLevenbergMarquardt };
inline constexpr EnumName<SolverType> kSolverTypeNames[] = {
    {SolverType::kDogleg, "dogleg"}, {SolverType::kLevenbergMarquardt, "levenberg_marquardt"}};

inline constexpr EnumName<AlignmentMode> kAlignmentModeNames[] = {{AlignmentMode::kSe3, "se3"},
                                                                  {AlignmentMode::kSim3, "sim3"},
                                                                  {AlignmentMode::kPosYaw, "posyaw"},
                                                                  {AlignmentMode::kNone, "none"}};

struct InitializerOptions {
  int window_size = 10;
  int min_correspondences = 20;               // with the newest frame, per camera
  double min_parallax_px = 30.0;              // mean, at focal 460
  int min_cameras_passing = 2;                // fallback when not all cameras pass
  std::vector<std::string> required_cameras;  // empty: "all" in JSON
  double scale_initial_guess = 10.0;

  void Check() const;
};

struct BackendOptions {
  int window_size = 10;  // keyframes, plus the newest frame
  SolverType solver = SolverType::kDogleg;
  int max_iterations = 8;
  double max_solver_time_s = 0.0;     // 0: no limit (required in deterministic mode)
  LossType loss = LossType::kCauchy;  // the release uses Cauchy(1); the paper says Huber
  double loss_scale = 1.0;
  double reprojection_sigma_px = 1.5;  // at focal virtual_focal_px (information 460 / 1.5)
  double virtual_focal_px = 460.0;
  double init_depth_m = 5.0;  // depth prior of a new landmark
  int min_observations = 2;   // landmarks seen fewer times are not optimised
  double keyframe_parallax_px = 10.0;
  int keyframe_min_tracked = 20;
  int scale_correction_period = 50;  // solves between scale corrections; 0: never
  bool refine_extrinsics = false;

  void Check() const;
};

struct LoopOptions {
  bool enabled = true;
  std::string vocabulary_path;  // empty: the built-in vocabulary
  int features_per_camera = 500;
  int exclude_recent_keyframes = 50;
  double min_score = 0.015;
  double min_camera_fraction = 0.5;  // verification needs more than this fraction of cameras

  void Check() const;
};

struct RuntimeOptions {
  int threads = 0;  // 0: hardware concurrency
  int64_t seed = 0;
  bool deterministic = true;

  void Check() const;
};

struct PipelineOptions {
  FrontendOptions frontend;
  InitializerOptions initializer;
  BackendOptions backend;
  LoopOptions loop;
  RuntimeOptions runtime;
  EvalOptions eval;  // the component's own options (eval/evaluate.h)

  // Checks every section and the constraints between sections.
  void Check() const;
};

}  // namespace mcvo
