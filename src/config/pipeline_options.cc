// Check() of every options struct. Messages name the field by its JSON path
// in the config file (docs/config.md).
#include "mcvo/config/pipeline_options.h"

#include <set>
#include <string>

#include "mcvo/config/option_bounds.h"
#include "mcvo/util/error.h"
#include "mcvo/util/option_checks.h"
#include "mcvo/util/strings.h"

namespace mcvo {

void DatasetSelectionOptions::Check() const {
  std::set<std::string> seen;
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (cameras[i].empty()) MCVO_THROW_INPUT("/dataset/cameras/", i, ": empty camera name");
    if (!seen.insert(cameras[i]).second) {
      MCVO_THROW_INPUT("/dataset/cameras/", i, ": camera \"", cameras[i], "\" listed twice");
    }
  }
}

void LoopOptions::Check() const {
  CheckAtLeast("/loop/relocalise_map_keyframes", relocalise_map_keyframes, 1);
  CheckAtLeast("/loop/relocalise_query_keyframes", relocalise_query_keyframes, 1);
  CheckAtLeast("/loop/frontend_cache_mb", frontend_cache_mb, 0);
  closure.Check();
  pose_graph.Check();
}

std::string DefaultVocabularyPath() { return MCVO_DEFAULT_VOCABULARY; }

void ColmapOutputOptions::Check() const {
  export_options.Check();
  if (enabled && export_options.fisheye_policy == ColmapFisheyePolicy::kUndistort &&
      export_options.image_mode == ColmapImageMode::kNone) {
    MCVO_THROW_INPUT(
        "/colmap/fisheye_policy: \"undistort\" writes undistorted images and needs image_mode "
        "\"link\" or \"copy\", got \"none\"");
  }
}

void RuntimeOptions::Check() const { CheckAtLeast("/runtime/threads", threads, 0); }

void PipelineOptions::Check() const {
  dataset.Check();
  frontend.Check();
  initializer.Check();
  backend.Check();
  loop.Check();
  refine.Check();
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
  colmap.Check();
  CheckOptionBounds(*this);
}

}  // namespace mcvo
