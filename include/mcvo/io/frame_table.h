// The frame table of the generic rig dataset format (docs/dataset-format.md):
// frames.csv, one row per synchronized multi-camera frame.
//
//   t_ns,image_00,image_01,image_02
//   1000000000,images/image_00/000000.png,images/image_01/000000.png,
//
// The header names the cameras in rig.json order (same names). A row holds
// the frame time in integer nanoseconds and one image path per camera,
// relative to the folder of frames.csv; an empty field marks a missing image.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace mcvo {

struct FrameTableRow {
  int64_t t_ns = 0;
  std::vector<std::string> image_paths;  // one per camera; "" = missing
};

struct FrameTable {
  std::vector<std::string> camera_names;
  std::vector<FrameTableRow> rows;
};

// Writes atomically. MCVO_CHECKs that every row has one path per camera.
void WriteFrameTable(const std::filesystem::path& path, const FrameTable& table);

// Reads and validates: header "t_ns,<names...>" with unique names, every row
// with the same number of fields, integer times strictly increasing, no
// commas or blanks in paths. Errors: InputError "<file>:<line>: <what>".
FrameTable ReadFrameTable(const std::filesystem::path& path);
// As ReadFrameTable, from the file's text; `source` names it in errors.
FrameTable ParseFrameTable(const std::string& text, const std::string& source);

}  // namespace mcvo
