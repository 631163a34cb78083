// The odometry stage of `mcvo run` (private to pipeline/): the forward
// estimator over the frames as the frontend delivers them, then what an
// offline tool can do with the whole sequence:
//   1. fallback: when no frame was posed and some initializer window failed
//      only its scale-uncertainty bound, with a std of at most
//      initializer.max_relative_scale_sigma_fallback, the frames run through
//      a new estimator with that relaxed bound (logged);
//   2. the reverse pass (backend/reverse_pass.h) poses the frames before
//      each initialisation at the scale found later.
// Deterministic: everything runs in frame order on the calling thread.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mcvo/backend/estimator.h"
#include "mcvo/backend/reverse_pass.h"
#include "mcvo/config/pipeline_options.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/geometry/sim3d.h"
#include "mcvo/io/trajectory_io.h"

namespace mcvo::pipeline_internal {

// What the forward pass made of one frame (its pose updates are in the
// stage's pose map), for frame_stats.csv and timing.csv.
struct FrameRecord {
  FrameEstimate estimate;  // poses cleared
  size_t cross_camera = 0;
  double frontend_seconds = 0.0;
  double backend_seconds = 0.0;
};

struct StageSeconds {
  double frontend = 0, initializer = 0, pnp = 0, ba = 0, marginalization = 0, scale = 0, backend = 0;
};

struct OdometryOutput {
  std::map<int, StampedPose> poses;  // frame index -> final pose
  std::vector<KeyframeEstimate> keyframes;       // frame order
  std::map<int64_t, Eigen::Vector3d> landmarks;  // id -> final position
  std::vector<ScaleLogEntry> scale_log;          // frame order
  std::vector<FrameRecord> records;              // one per frame, frame order
  std::map<int, int> reverse_posed;              // frames the reverse pass posed -> segment
  int segments = 1;
  StageSeconds totals;
  double reverse_seconds = 0.0;
  // > 0 when the fallback ran: the relaxed scale-uncertainty bound.
  double fallback_sigma = 0.0;
  // >= 0 when the monocular fallback posed the sequence: the rig camera it
  // used alone (the records, poses, keyframes and landmarks are of a
  // one-camera rig of it, its origin at the camera centre), and why.
  int monocular_camera = -1;
  std::string monocular_reason;
  // Passes of the frames through an estimator: 1, one more for the
  // fallback bound / overlap start at once, one more for the monocular
  // fallback (each counted when it ran, posed or not).
  int passes = 1;
};

class OdometryStage {
 public:
  OdometryStage(const Rig& rig, const PipelineOptions& options, int threads);
  // The next frame, in frame order, with the frontend's wall time for it.
  void Add(const RigFrameObservations& frame, double frontend_seconds);
  // Ends the forward pass, runs the fallback and the reverse pass.
  OdometryOutput Finish();
  // Between Add calls (the forward pass): the keyframes finished so far, in
  // the order they finished, and the frames that may still become finished
  // keyframes of the forward pass (Estimator::PendingFrames). For the loop
  // image cache (loop_image_cache.h).
  const std::vector<KeyframeEstimate>& FinishedKeyframes() const { return out_.keyframes; }
  std::vector<int> PendingFrames() const { return estimator_->PendingFrames(); }

 private:
  void Consume(Estimator* estimator, ReversePass* reverse, const RigFrameObservations& frame,
               double frontend_seconds, OdometryOutput* out);
  void FinishEstimator(Estimator* estimator, ReversePass* reverse, OdometryOutput* out);
  void MonocularFallback();

  const Rig rig_;
  const PipelineOptions options_;
  const int threads_;
  std::unique_ptr<Estimator> estimator_;
  std::unique_ptr<ReversePass> reverse_;
  OdometryOutput out_;
  // Every frame while none is posed: what the fallback runs over.
  std::vector<RigFrameObservations> unposed_;
  std::vector<double> unposed_frontend_seconds_;
};

// Posed frame -> its segment (the reverse pass's segment for the frames it posed).
std::map<int, int> SegmentOfPosedFrames(const OdometryOutput& out);
// Moves every pose, keyframe (with its observation points) and landmark of
// each segment in `correction` by it (world_new_from_world_old, a rigid
// motion, or a similarity for a monocular segment whose unit changes); a
// landmark belongs to the segment of the last keyframe that observed it.
void MoveSegments(const std::map<int, Sim3d>& correction, OdometryOutput* out);

std::string FrameStatsCsv(const Rig& rig, const OdometryOutput& odometry);
std::string TimingCsv(const OdometryOutput& odometry);

}  // namespace mcvo::pipeline_internal
