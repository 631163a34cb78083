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
//   1. Seeded (the default): a second Estimator (same options) starts at the
//      forward pass's final poses of the segment's first keyframes (at most
//      window_size, within overlap_frames of f_s; Estimator::StartFromPoses:
//      held fixed while they are in its window), in reverse time order, and
//      tracks backwards from f_s - 1 down to the first unposed frame. Its
//      world is the forward world and its scale the forward segment's from
//      the first frame on: the frames before get the scale that was
//      determined later ("scale applied back") without a second
//      initialisation. A reverse initialisation measures the scale again
//      from the same corner, seen backwards, and can disagree with the
//      forward one (seed-11 case of results/robustness_seed11.md: 1.40x).
//   2. When the seeded run poses none of the unposed frames (the seeds
//      cannot be triangulated, e.g. a rig that stood still there), or loses
//      track before the first of them and this run gets further (kept only
//      then: a marginal frame, e.g. one camera blacked out, can fail one run
//      and not the other), or with seed_from_forward off: the reverse
//      Estimator runs over the frames
//      from f_s + overlap_frames down, initialises on its own where the
//      scale is observable seen backwards, and its world is aligned to the
//      forward world on the frames both posed: rotation as the chordal mean
//      of the per-frame rotation differences (well defined also on a
//      straight line, where positions alone leave the roll about the line
//      free), then scale and translation by least squares on the positions.
//      Scale outside [0.8, 1.25] or fewer than min_overlap_poses common
//      frames: the alignment is refused and the frames stay unposed (with
//      the reason).
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
  bool seed_from_forward = true;  // step 1; false: only the aligned run (step 2)
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
  bool seeded = false;          // posed by the seeded run (step 1), else by the aligned one
  int reverse_init_frame = -1;  // where the reverse estimator initialised or was seeded (-1: never)
  int frames_posed = 0;         // unposed frames it posed
  int first_frame_posed = -1;   // earliest of them (-1: none)
  int overlap_poses = 0;        // frames posed by both, used for the alignment (seeded: the seeds)
  Sim3d forward_from_reverse;   // the alignment (identity when refused or seeded)
  double align_rms_m = 0.0;     // position rms after alignment, over the overlap (seeded: 0)
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
  // Keyframes of the forward estimator as they leave its window
  // (Estimator::TakeFinishedKeyframes, Finish): their final poses replace
  // the poses their frames got when tracked, for the seeds and the alignment.
  void AddKeyframes(const std::vector<KeyframeEstimate>& keyframes);
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
