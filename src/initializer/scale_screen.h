// Step 4 of the initializer (initializer.h): the metric scale of each
// camera's window SfM from the rig constraint and the cross-camera
// measurements, screened by its uncertainty before the rig window BA.
// Internal to the module.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "mcvo/camera/camera.h"
#include "mcvo/initializer/camera_sfm.h"
#include "mcvo/initializer/initializer.h"
#include "mcvo/initializer/rig_scale.h"

namespace mcvo::initializer_internal {

struct ScaleScreen {
  bool ok = false;
  std::string reason;  // why not, when !ok: one line, cameras by name
  // When the screen rejected the window for its uncertainty alone: the best
  // camera's relative scale std over the screen's bound (> 1; infinity when
  // no camera's scale was positive). 0 otherwise.
  double poor_ratio = 0.0;
  // For that rejection with a finite ratio: the max_relative_scale_sigma
  // that would have let the window through (the offline fallback's test,
  // Initializer::SmallestRejectedScaleSigma). Infinity otherwise.
  double passing_bound = std::numeric_limits<double>::infinity();
};

// The combined solve runs without its per-camera uncertainty test; the
// window is rejected unless the best determined camera's scale has a
// relative std of at most kLinearGateFactor x max_relative_scale_sigma
// (1 x with the rig BA off). That is a screen only (it spares the rig BA
// hopeless windows): the rig BA, which uses every observation at once,
// estimates the scale and its uncertainty again and applies
// max_relative_scale_sigma itself (with the BA off, the principal camera's
// linear sigma must pass it). A camera whose scale is not positive or less
// certain than kMaxCameraRelativeSigma is left out (DropCamera: used,
// sfm_of_used, tracks and measurements shrink together; its landmarks would
// start too far off) and the solve repeated. On success result->rig_scale
// and result->source are set.
ScaleScreen ScreenScale(const Rig& rig, const InitializerOptions& options, std::vector<int>* used,
                        std::vector<CameraSfmResult>* sfm_of_used, std::vector<CameraWindowTrack>* tracks,
                        std::vector<ScaleMeasurement>* measurements, InitializationResult* result);

// Leaves camera k (an index into used) out of the solve.
void DropCamera(size_t k, std::vector<int>* used, std::vector<CameraSfmResult>* sfm_of_used,
                std::vector<CameraWindowTrack>* tracks, std::vector<ScaleMeasurement>* measurements);

// sigma_k / s_k per camera of a solution (infinity for a scale that is not positive).
std::vector<double> RelativeSigmas(const RigScaleResult& solve);

}  // namespace mcvo::initializer_internal
