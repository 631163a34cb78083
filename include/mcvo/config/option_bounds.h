// Upper bounds of the config's integer keys, and the bounds that depend on
// the images of the rig. Each options struct's Check() sets the lower bounds;
// these keep a value that is allowed there from exhausting memory or time
// (an LK window of 100001 px, a sliding window of 2e9 keyframes). Every bound
// is listed beside its key in docs/config.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mcvo/camera/camera.h"
#include "mcvo/config/pipeline_options.h"

namespace mcvo {

// One integer key of the config: its JSON pointer, its value and its maximum.
struct OptionBound {
  const char* pointer;
  int64_t value;
  int64_t max;
};

// Every integer key of the config but /runtime/seed (any seed is fine), in
// file order, with its value in `options`.
std::vector<OptionBound> OptionBounds(const PipelineOptions& options);

// Throws InputError "<pointer>: <value> is above the maximum <max>" for the
// first key of OptionBounds over its maximum (PipelineOptions::Check).
void CheckOptionBounds(const PipelineOptions& options);

// The bounds that need the image sizes, on each camera's values after
// ScalePixelParameters (what its tracker uses): the LK window (lk.window_px)
// must be smaller than the image (OpenCV builds only the pyramid levels that
// are larger than the window), the CLAHE grid (clahe.tile_grid, when
// enabled) at most the image's smaller side, the anchor template (2
// anchor.half_size_px + 1, when enabled) at most the smaller side. Throws
// InputError "<config_source>: <pointer>: <value> ... camera <name> (W x H
// px)". Call once the dataset is open, before any image is decoded.
void CheckOptionsAgainstRig(const PipelineOptions& options, const Rig& rig, const std::string& config_source);

}  // namespace mcvo
