// libFuzzer target: trajectory text -> DetectTrajectoryFormatFromText and
// ParseTrajectory in every format (TUM, KITTI, KITTI-indexed, EuRoC;
// src/io/trajectory_io.cc). Contract (docs/fuzzing.md): returns poses or
// throws InputError naming the source and line; every pose that parses has
// a unit quaternion and finite numbers, in strictly increasing time (TUM,
// EuRoC) or frame index order (KITTI-indexed).
#include <cmath>
#include <cstdlib>
#include <string>

#include "fuzz/fuzz_util.h"
#include "mcvo/io/trajectory_io.h"

namespace {

void CheckTrajectory(const mcvo::Trajectory& trajectory, mcvo::TrajectoryFormat format) {
  for (size_t i = 0; i < trajectory.poses.size(); ++i) {
    const mcvo::StampedPose& pose = trajectory.poses[i];
    if (std::abs(pose.world_from_body.rotation.norm() - 1.0) > 1e-9) std::abort();
    if (!pose.world_from_body.translation.allFinite()) std::abort();
    if (i == 0) continue;
    const mcvo::StampedPose& previous = trajectory.poses[i - 1];
    if (trajectory.has_time && pose.t_ns <= previous.t_ns) std::abort();
    if (format == mcvo::TrajectoryFormat::kKittiIndexed && pose.frame_index <= previous.frame_index)
      std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string source = "fuzz/trajectory.txt";
  mcvo::fuzz::ExpectOnlyInputErrors(source, [&] {
    const mcvo::TrajectoryFormat format = mcvo::DetectTrajectoryFormatFromText(text, source);
    CheckTrajectory(mcvo::ParseTrajectory(text, source, format), format);
  });
  for (const mcvo::TrajectoryFormat format :
       {mcvo::TrajectoryFormat::kTum, mcvo::TrajectoryFormat::kKitti, mcvo::TrajectoryFormat::kKittiIndexed,
        mcvo::TrajectoryFormat::kEuroc}) {
    mcvo::fuzz::ExpectOnlyInputErrors(
        source, [&] { CheckTrajectory(mcvo::ParseTrajectory(text, source, format), format); });
  }
  return 0;
}
