// Trajectory files: TUM, KITTI (optionally with a leading frame index, as
// KITTI-360 poses.txt) and EuRoC CSV. Conventions in
// ../shared/reference/formats-and-evaluation.md and docs/trajectory-formats.md.
//
// Every pose is world_from_body. Time inside the program is int64 ns.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

struct StampedPose {
  int64_t t_ns = 0;          // time stamp; KITTI files have none (0 unless a times file gives it)
  int64_t frame_index = -1;  // KITTI line or frame index; -1 when the format has none
  Rigid3d world_from_body;
};

enum class TrajectoryFormat {
  kTum,           // "t tx ty tz qx qy qz qw", t in seconds
  kKitti,         // 12 numbers: row-major 3x4 world_from_body, line i = frame i
  kKittiIndexed,  // frame index + 12 numbers (KITTI-360 poses.txt)
  kEuroc,         // "t_ns, px, py, pz, qw, qx, qy, qz[, ...]" (ground-truth CSV)
};

struct Trajectory {
  std::vector<StampedPose> poses;
  bool has_time = false;         // t_ns meaningful
  bool has_frame_index = false;  // frame_index meaningful
};

// "tum", "kitti", "kitti-indexed" (alias "kitti360"), "euroc".
std::optional<TrajectoryFormat> TrajectoryFormatFromName(std::string_view name);
std::string_view TrajectoryFormatName(TrajectoryFormat format);
// Guesses the format from the first data line (number of fields, commas).
// Throws InputError naming the file when no format fits.
TrajectoryFormat DetectTrajectoryFormat(const std::filesystem::path& path);
// As DetectTrajectoryFormat, from the file's text; `source` names it in errors.
TrajectoryFormat DetectTrajectoryFormatFromText(const std::string& content, const std::string& source);

// Reads a trajectory. Malformed lines throw InputError "<file>:<line>: <what>".
// Lines starting with '#' and blank lines are skipped. Non-finite numbers,
// rotations that are not orthonormal (KITTI, tolerance 1e-4 on R^T R - I,
// re-orthonormalised after the check) and quaternions far from unit norm
// (|1 - |q|| > 1e-3, normalised after the check) are errors. Poses must be
// in strictly increasing time (TUM, EuRoC) or frame index (KITTI-indexed)
// order: a duplicate or a step back is an error. KITTI-indexed also accepts
// index + 16 numbers (KITTI-360 cam0_to_world.txt, last row 0 0 0 1).
Trajectory ReadTrajectory(const std::filesystem::path& path, TrajectoryFormat format);
// As ReadTrajectory, from the file's text; `source` names it in errors.
Trajectory ParseTrajectory(const std::string& content, const std::string& source, TrajectoryFormat format);

// Reads a KITTI-style times file (one time per line, line i = frame i: either
// seconds, as KITTI times.txt, or "YYYY-MM-DD HH:MM:SS.fraction" taken as UTC,
// as KITTI-360 timestamps.txt) and sets t_ns of every pose of a KITTI
// trajectory by frame index. Throws when a frame index has no time or the
// times do not increase.
void ApplyTimesFile(const std::filesystem::path& times_path, Trajectory* trajectory);

// Writes atomically. Numbers round-trip exactly (shortest representation).
void WriteTrajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                     TrajectoryFormat format);

}  // namespace mcvo
