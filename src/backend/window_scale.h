// Scale correction of the window (estimator.h step 6): the initialiser's
// metric rig window BA (initializer/rig_window_ba.h) re-estimates the window
// from its own observations, without the marginalisation prior, with the
// oldest keyframe fixed; its travel over the current estimate's travel is a
// measurement of the scale error. ScaleFilter (scale_filter.h) fuses it with
// the current scale, and the fused ratio is applied to the window (positions
// about the oldest keyframe, the prior's linearisation positions, the last
// poses of the constant-velocity prediction, each camera's landmark depths).
// Every attempt is described by one scale-log entry.
// Private to the back end (src/backend).
#pragma once

#include <optional>

#include "landmark_window.h"
#include "mcvo/backend/backend_options.h"
#include "mcvo/backend/estimator.h"
#include "mcvo/backend/scale_filter.h"
#include "mcvo/camera/camera.h"
#include "window_problem.h"

namespace mcvo::backend_internal {

class WindowScaleCorrector {
 public:
  WindowScaleCorrector(const Rig& rig, const BackendOptions& options);

  // The current scale's uncertainty (started by the estimator at each initialisation).
  ScaleFilter& filter() { return filter_; }

  struct Outcome {
    ScaleLogEntry entry;    // event "correction", applied or not and why
    bool measured = false;  // a measurement reached the filter (applied or not)
  };
  // One attempt on the window, whose newest frame is `newest`. The poses
  // *last_pose and *previous_pose (the constant-velocity prediction) move
  // with the window when the correction is applied.
  Outcome Correct(const WindowFrame& newest, int segment, LandmarkWindow* window, WindowProblem* problem,
                  std::optional<Rigid3d>* last_pose, std::optional<Rigid3d>* previous_pose);

 private:
  // Per camera: the fused ratio of its landmark depths (see Correct).
  std::vector<double> CameraRatios(const LandmarkWindow& window,
                                   const std::vector<Rigid3d>& refined_world_from_rig,
                                   const std::map<uint64_t, Eigen::Vector3d>& refined_points, double gain,
                                   double k) const;

  const Rig rig_;
  const BackendOptions options_;
  ScaleFilter filter_;
};

}  // namespace mcvo::backend_internal
