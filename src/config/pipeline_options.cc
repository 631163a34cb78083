// Check() of every options struct. Messages name the field by its JSON path
// in the config file (docs/config.md).
#include "mcvo/config/pipeline_options.h"

#include <set>
#include <string>

#include "mcvo/util/error.h"
#include "mcvo/util/option_checks.h"
#include "mcvo/util/strings.h"

namespace mcvo {

void InitializerOptions::Check() const {
  CheckAtLeast("/initializer/window_size", window_size, 2);
  // A fundamental matrix needs 8 correspondences.
  CheckAtLeast("/initializer/min_correspondences", min_correspondences, 8);
  CheckAtLeast("/initializer/min_parallax_px", min_parallax_px, 0.0);
  CheckAtLeast("/initializer/min_cameras_passing", min_cameras_passing, 1);
  std::set<std::string> seen;
  for (size_t i = 0; i < required_cameras.size(); ++i) {
    if (required_cameras[i].empty())
      MCVO_THROW_INPUT("/initializer/required_cameras/", i, ": empty camera name");
    if (!seen.insert(required_cameras[i]).second) {
      MCVO_THROW_INPUT("/initializer/required_cameras/", i, ": camera \"", required_cameras[i],
                       "\" listed twice");
    }
  }
  CheckPositive("/initializer/scale_initial_guess", scale_initial_guess);
}

void BackendOptions::Check() const {
  CheckAtLeast("/backend/window_size", window_size, 2);
  CheckAtLeast("/backend/max_iterations", max_iterations, 1);
  CheckAtLeast("/backend/max_solver_time_s", max_solver_time_s, 0.0);
  CheckPositive("/backend/loss_scale", loss_scale);
  CheckPositive("/backend/reprojection_sigma_px", reprojection_sigma_px);
  CheckPositive("/backend/virtual_focal_px", virtual_focal_px);
  CheckPositive("/backend/init_depth_m", init_depth_m);
  CheckAtLeast("/backend/min_observations", min_observations, 2);
  CheckAtLeast("/backend/keyframe_parallax_px", keyframe_parallax_px, 0.0);
  CheckAtLeast("/backend/keyframe_min_tracked", keyframe_min_tracked, 0);
  CheckAtLeast("/backend/scale_correction_period", scale_correction_period, 0);
}

void LoopOptions::Check() const {
  CheckAtLeast("/loop/features_per_camera", features_per_camera, 1);
  CheckAtLeast("/loop/exclude_recent_keyframes", exclude_recent_keyframes, 0);
  CheckInRange("/loop/min_score", min_score, 0.0, 1.0);
  CheckInRange("/loop/min_camera_fraction", min_camera_fraction, 0.0, 1.0);
}

void RuntimeOptions::Check() const { CheckAtLeast("/runtime/threads", threads, 0); }

void PipelineOptions::Check() const {
  frontend.Check();
  initializer.Check();
  backend.Check();
  loop.Check();
  runtime.Check();
  try {
    eval.Check();
  } catch (const UsageError& e) {
    // EvalOptions::Check names the field ("align_num_poses: ..."); here it
    // comes from the config file, so it is bad input at /eval/<field>.
    MCVO_THROW_INPUT("/eval/", e.what());
  }
  if (runtime.deterministic && backend.max_solver_time_s > 0.0) {
    MCVO_THROW_INPUT(
        "/backend/max_solver_time_s: must be 0 when /runtime/deterministic is true (a wall-clock ",
        "limit makes results depend on machine load), got ", OptionText(backend.max_solver_time_s));
  }
  if (initializer.window_size > backend.window_size) {
    MCVO_THROW_INPUT("/initializer/window_size: must be <= /backend/window_size (", backend.window_size,
                     "), got ", initializer.window_size);
  }
}

}  // namespace mcvo
