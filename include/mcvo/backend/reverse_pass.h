// Offline completion of the frames the forward pass could not pose (issue
// "every frame posed"): an offline tool has the whole sequence, so the
// frames before a segment's metric initialisation need not stay unposed.
//
// Why they are unposed: a rig without overlapping views gets its metric
// scale only from rotation, so on a straight road the initializer waits
// (initializer.h) until the first corner; after a tracking loss the frames
// until the next initialisation wait the same way.
//
// What the reverse pass does, per segment s whose first posed frame f_s
// follows unposed frames (back to the previous posed frame, or frame 0):
//   1. A second Estimator (same options) runs over the frames from
//      f_s + overlap_frames down to the first unposed frame, in reverse time
//      order. Seen backwards, the sequence starts in the window that
//      initialised forwards, where the scale is observable, so the reverse
//      estimator initialises there, metric, and tracks backwards through the
//      frames the forward pass had to skip.
//   2. Its world is aligned to the forward world on the overlap frames (posed
//      by both): rotation as the chordal mean of the per-frame rotation
//      differences (well defined also on a straight line, where positions
//      alone leave the roll about the line free), then scale and translation
//      by least squares on the positions. The scale is the forward
//      segment's, so the frames before get the scale that was determined
//      later: "scale applied back". Scale outside [0.8, 1.25] or fewer than
//      min_overlap_poses common frames: the alignment is refused and the
//      frames stay unposed (with the reason).
//   3. The reverse estimator's poses of the unposed frames, its keyframes
//      among them and its landmarks are mapped into the forward world.
// Only the reverse run's segment that holds the overlap is used (if it
// loses track itself, the frames beyond stay unposed).
//
// Memory: only the frames a reverse pass may need are kept: unposed frames
// and the first overlap_frames posed frames of each segment.
// Deterministic: the reverse Estimator is, and everything here is
// sequential in frame order.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mcvo/backend/estimator.h"
#include "mcvo/geometry/sim3d.h"

namespace mcvo {

struct ReversePassOptions {
  // Forward-posed frames after a segment's first pose that the reverse pass
  // runs over too: where it initialises and where its world is aligned.
  int overlap_frames = 40;
  int min_overlap_poses = 5;
  double min_scale = 0.8, max_scale = 1.25;  // accepted Sim3 scale of the alignment
};

struct BackfilledFrame {
  int frame_index = 0;
  int64_t t_ns = 0;
  int segment = 0;  // the forward segment whose world and scale it got
  Rigid3d world_from_rig;
};

// One reverse pass (one forward segment with unposed frames before it).
struct ReversePassReport {
  int segment = 0;              // the forward segment
  int first_posed_frame = 0;    // f_s: its first frame posed by the forward pass
  int first_unposed_frame = 0;  // the earliest frame the pass tried to pose
  int reverse_init_frame = -1;  // where the reverse estimator initialised (-1: never)
  int frames_posed = 0;         // unposed frames it posed
  int first_frame_posed = -1;   // earliest of them (-1: none)
  int overlap_poses = 0;        // frames posed by both, used for the alignment
  Sim3d forward_from_reverse;   // the alignment (identity when refused)
  double align_rms_m = 0.0;     // position rms after alignment, over the overlap
  bool applied = false;
  std::string note;  // what happened, one line
};

struct ReversePassResult {
  std::vector<BackfilledFrame> frames;        // frame order
  std::vector<KeyframeEstimate> keyframes;    // of the backfilled frames, forward world
  std::vector<MapLandmark> landmarks;         // of the reverse runs used, forward world
  std::vector<ReversePassReport> reports;     // one per segment with unposed frames before it
  std::vector<ScaleLogEntry> scale_log;       // one "backfill" entry per report
};

class ReversePass {
 public:
  ReversePass(const Rig& rig, const InitializerOptions& init_options, const BackendOptions& options,
              const ReversePassOptions& reverse_options, int threads);
  ~ReversePass();
  ReversePass(const ReversePass&) = delete;
  ReversePass& operator=(const ReversePass&) = delete;

  // Every frame of the forward pass, in frame order, with what the forward
  // estimator returned for it (its segment and the pose updates it made).
  void Add(const RigFrameObservations& frame, const FrameEstimate& estimate);
  // Runs the reverse passes over what was added (after the forward pass).
  ReversePassResult Run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The similarity that takes poses `from` onto poses `to` (paired): rotation
// as the chordal mean of to_i.R from_i.R^T, then scale and translation by
// least squares on the positions; scale fixed to 1 when the positions span
// less than 1 cm (rms about their mean). *rms_m: position rms after it.
// Needs at least one pair.
Sim3d AlignPosesSim3(const std::vector<Rigid3d>& from, const std::vector<Rigid3d>& to, double* rms_m);

}  // namespace mcvo
