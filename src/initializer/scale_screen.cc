// Step 4 of the initializer: the scale screen (scale_screen.h).
#include "scale_screen.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::initializer_internal {
namespace {

// "camera 3" in a rig-scale reason -> the name of the rig camera behind solve index 3.
std::string NameCameras(std::string text, const std::vector<int>& solve_to_rig, const Rig& rig) {
  for (int k = static_cast<int>(solve_to_rig.size()) - 1; k >= 0; --k) {
    const std::string from = StrCat("camera ", k);
    const std::string to =
        StrCat("camera ", rig.cameras[static_cast<size_t>(solve_to_rig[static_cast<size_t>(k)])].name);
    size_t pos = text.find(from);
    while (pos != std::string::npos) {
      const size_t end = pos + from.size();
      if (end < text.size() &&
          std::isdigit(static_cast<unsigned char>(text[end]))) {  // "camera 12" for k = 1
        pos = text.find(from, end);
        continue;
      }
      text.replace(pos, from.size(), to);
      pos = text.find(from, pos + to.size());
    }
  }
  return text;
}

}  // namespace

ScaleScreen ScreenScale(const Rig& rig, const InitializerOptions& options, std::vector<int>* used,
                        std::vector<CameraSfmResult>* sfm_of_used, std::vector<CameraWindowTrack>* tracks,
                        std::vector<ScaleMeasurement>* measurements, InitializationResult* result) {
  ScaleScreen screen;
  constexpr double kMaxCameraRelativeSigma = 0.1;
  constexpr double kLinearGateFactor = 3.0;
  const double gate =
      (options.max_rig_ba_iterations > 0 ? kLinearGateFactor : 1.0) * options.max_relative_scale_sigma;
  RigScaleOptions scale_options;
  scale_options.min_singular_value_ratio = options.min_singular_value_ratio;
  scale_options.max_rms_residual_m = options.max_rms_residual_m;
  scale_options.max_relative_scale_sigma = std::numeric_limits<double>::max();  // tested here, per camera
  scale_options.estimate_measurement_sigma = false;  // their sigmas come from their own scatter
  auto describe = [&](const std::string& text) {
    return StrCat(NameCameras(text, *used, rig), " [", used->size(), " cameras, ",
                  result->cross_camera_matches, " cross-camera matches]");
  };
  for (;;) {
    if (used->size() < 2 && measurements->empty()) {
      screen.reason =
          StrCat("scale not observable: one camera (", rig.cameras[static_cast<size_t>(used->front())].name,
                 ") and no cross-camera observation");
      return screen;
    }
    RigScaleResult solve = SolveRigScalesCombined(*tracks, *measurements, scale_options);
    if (solve.solution.empty()) {
      screen.reason = describe(solve.reason);
      return screen;
    }
    const std::vector<double> relative = RelativeSigmas(solve);
    const size_t best =
        static_cast<size_t>(std::min_element(relative.begin(), relative.end()) - relative.begin());
    const size_t worst =
        static_cast<size_t>(std::max_element(relative.begin(), relative.end()) - relative.begin());
    if (!(relative[best] <= gate)) {
      screen.poor_ratio = relative[best] / gate;  // infinity when no scale is positive
      if (std::isfinite(relative[best])) {
        screen.passing_bound = relative[best] * options.max_relative_scale_sigma / gate;
      }
      screen.reason =
          describe(std::isfinite(relative[best])
                       ? StrCat("scale poorly observable: best determined camera ", best,
                                " has a scale sigma of ", FormatFixed(100.0 * relative[best], 2), " % > ",
                                FormatFixed(100.0 * gate, 2), " % (linear solve)")
                       : StrCat("scale poorly observable: no camera has a positive scale (linear solve)"));
      return screen;
    }
    if (!(relative[worst] <= kMaxCameraRelativeSigma)) {
      DropCamera(worst, used, sfm_of_used, tracks, measurements);
      continue;
    }
    if (!solve.observable) {
      screen.reason = describe(solve.reason);
      return screen;
    }
    result->rig_scale = solve;
    break;
  }
  if (measurements->empty()) {
    result->source = ScaleSource::kRigRotation;
  } else {
    // Combined when the rig rotation alone would also have passed.
    bool rotation_alone = false;
    if (used->size() >= 2) {
      const RigScaleResult rig_only = SolveRigScalesCombined(*tracks, {}, scale_options);
      if (!rig_only.solution.empty() && rig_only.observable) {
        const std::vector<double> relative = RelativeSigmas(rig_only);
        rotation_alone =
            *std::min_element(relative.begin(), relative.end()) <= options.max_relative_scale_sigma;
      }
    }
    result->source = rotation_alone ? ScaleSource::kCombined : ScaleSource::kCrossCamera;
  }
  screen.ok = true;
  return screen;
}

void DropCamera(size_t k, std::vector<int>* used, std::vector<CameraSfmResult>* sfm_of_used,
                std::vector<CameraWindowTrack>* tracks, std::vector<ScaleMeasurement>* measurements) {
  used->erase(used->begin() + static_cast<std::ptrdiff_t>(k));
  sfm_of_used->erase(sfm_of_used->begin() + static_cast<std::ptrdiff_t>(k));
  tracks->erase(tracks->begin() + static_cast<std::ptrdiff_t>(k));
  std::vector<ScaleMeasurement> kept;
  for (ScaleMeasurement m : *measurements) {
    if (m.camera == static_cast<int>(k)) continue;
    if (m.camera > static_cast<int>(k)) --m.camera;
    kept.push_back(m);
  }
  measurements->swap(kept);
}

std::vector<double> RelativeSigmas(const RigScaleResult& solve) {
  std::vector<double> relative(solve.solution.size());
  for (size_t k = 0; k < relative.size(); ++k) {
    relative[k] = solve.solution[k] > 0.0 ? solve.solution_sigmas[k] / solve.solution[k]
                                          : std::numeric_limits<double>::infinity();
  }
  return relative;
}

}  // namespace mcvo::initializer_internal
