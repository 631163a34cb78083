// The track file of `mcvo track` (format: docs/track-format.md): every frame's
// features per camera (id, pixel, score, track length, descriptor) and its
// cross-camera matches, enough for the back end to run without the images.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mcvo/frontend/multi_camera_tracker.h"

namespace mcvo {

struct TrackFileHeader {
  // Set by the reader from the file (1: written before cross-camera matches
  // existed, read with none). The writer always writes the current version.
  int format_version = 2;
  std::vector<std::string> camera_names;
  int descriptor_size = 0;  // per feature; 0: none
  int descriptor_type = 0;  // OpenCV depth of descriptor rows (CV_32F or CV_8U)
  std::string detector;     // detector name
  std::string config_json;  // the resolved config that produced the file
};

// Writes to "<path>.tmp.<pid>" and renames on Commit(): an interrupted run
// leaves no track file that looks complete.
class TrackFileWriter {
 public:
  TrackFileWriter(const std::filesystem::path& path, const TrackFileHeader& header);
  ~TrackFileWriter();
  void Write(const MultiCameraFrame& frame);
  void Commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Reads a track file frame by frame. A truncated or corrupt file throws
// InputError naming the file and the byte offset. Reads format versions 1
// (frames without cross-camera matches or pair statistics) and 2.
class TrackFileReader {
 public:
  explicit TrackFileReader(const std::filesystem::path& path);
  ~TrackFileReader();
  const TrackFileHeader& header() const;
  std::optional<MultiCameraFrame> Next();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
