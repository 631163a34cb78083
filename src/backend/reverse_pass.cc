#include "mcvo/backend/reverse_pass.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <utility>

#include <Eigen/SVD>

#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {

Sim3d AlignPosesSim3(const std::vector<Rigid3d>& from, const std::vector<Rigid3d>& to, double* rms_m) {
  MCVO_CHECK_MSG(!from.empty() && from.size() == to.size(), "AlignPosesSim3: ", from.size(), " vs ",
                 to.size(), " poses");
  const size_t n = from.size();
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d mean_from = Eigen::Vector3d::Zero(), mean_to = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    sum += to[i].rotation.toRotationMatrix() * from[i].rotation.toRotationMatrix().transpose();
    mean_from += from[i].translation;
    mean_to += to[i].translation;
  }
  mean_from /= static_cast<double>(n);
  mean_to /= static_cast<double>(n);
  // Chordal mean: the rotation nearest to the sum (projection onto SO(3)).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d rotation = svd.matrixU() * d * svd.matrixV().transpose();
  double numerator = 0.0, denominator = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = rotation * (from[i].translation - mean_from);
    numerator += (to[i].translation - mean_to).dot(p);
    denominator += p.squaredNorm();
  }
  constexpr double kMinSpreadM = 0.01;
  const double spread = std::sqrt(denominator / static_cast<double>(n));
  const double scale = spread >= kMinSpreadM && numerator > 0.0 ? numerator / denominator : 1.0;
  const Sim3d out(scale, Eigen::Quaterniond(rotation), mean_to - scale * (rotation * mean_from));
  if (rms_m != nullptr) {
    double sq = 0.0;
    for (size_t i = 0; i < n; ++i) sq += (out * from[i].translation - to[i].translation).squaredNorm();
    *rms_m = std::sqrt(sq / static_cast<double>(n));
  }
  return out;
}

struct ReversePass::Impl {
  Impl(const Rig& rig_in, const InitializerOptions& init_in, const BackendOptions& options_in,
       const ReversePassOptions& reverse_in, int threads_in)
      : rig(rig_in), init_options(init_in), options(options_in), reverse(reverse_in), threads(threads_in) {}

  const Rig rig;
  const InitializerOptions init_options;
  const BackendOptions options;
  const ReversePassOptions reverse;
  const int threads;

  struct Posed {
    int segment = 0;
    Rigid3d world_from_rig;
  };
  std::map<int, RigFrameObservations> kept;  // frames a reverse pass may need
  std::map<int, Posed> forward;              // forward poses (latest update)
  std::map<int, int> first_posed;            // segment -> first posed frame index
  std::set<int> final_keyframes;             // frames whose forward pose is a keyframe's final one

  void Add(const RigFrameObservations& frame, const FrameEstimate& estimate) {
    for (const PoseUpdate& update : estimate.poses) {
      forward[update.frame_index] = {estimate.segment, update.world_from_rig};
      auto [it, inserted] = first_posed.emplace(estimate.segment, update.frame_index);
      if (!inserted) it->second = std::min(it->second, update.frame_index);
    }
    auto first = first_posed.find(estimate.segment);
    const bool beyond_overlap = estimate.has_pose && first != first_posed.end() &&
                                frame.frame_index > first->second + reverse.overlap_frames;
    if (!beyond_overlap) kept[frame.frame_index] = frame;
  }

  void AddKeyframes(const std::vector<KeyframeEstimate>& keyframes) {
    for (const KeyframeEstimate& kf : keyframes) {
      auto it = forward.find(kf.frame_index);
      if (it == forward.end() || it->second.segment != kf.segment) continue;
      it->second.world_from_rig = kf.world_from_rig;
      final_keyframes.insert(kf.frame_index);
    }
  }

  // The reverse estimator over `frames` (descending frame index). Fills the
  // poses of its first segment, its keyframes and landmarks (reverse world,
  // original frame indices).
  struct ReverseRun {
    std::map<int, Rigid3d> poses;
    std::vector<KeyframeEstimate> keyframes;
    std::vector<MapLandmark> landmarks;
    int init_frame = -1;
    int lost_frame = -1;  // where it lost track (-1: never)
    std::string lost_reason;
  };
  // With seed_poses (forward world), the first seed_poses.size() frames
  // start the estimator at those poses (Estimator::StartFromPoses) instead
  // of its initializer: its world is then the forward world.
  ReverseRun RunReverse(const std::vector<const RigFrameObservations*>& frames,
                        const std::vector<Rigid3d>& seed_poses = {}, const std::string& seed_note = {}) const {
    ReverseRun run;
    const int top = frames.front()->frame_index;
    const int64_t top_t = frames.front()->t_ns;
    Estimator estimator(rig, init_options, options, threads);
    auto original = [&](int reversed) { return top - reversed; };
    auto take = [&](std::vector<KeyframeEstimate> keyframes) {
      for (KeyframeEstimate& kf : keyframes) {
        if (kf.segment != 0) continue;
        kf.frame_index = original(kf.frame_index);
        kf.t_ns = top_t - kf.t_ns;
        run.keyframes.push_back(std::move(kf));
      }
    };
    auto reverse_frame = [&](const RigFrameObservations& frame) {
      RigFrameObservations reversed = frame;
      reversed.frame_index = top - frame.frame_index;
      reversed.t_ns = top_t - frame.t_ns;
      return reversed;
    };
    size_t next = 0;
    if (!seed_poses.empty()) {
      std::vector<RigFrameObservations> seeds;
      for (; next < seed_poses.size(); ++next) seeds.push_back(reverse_frame(*frames[next]));
      const FrameEstimate estimate =
          estimator.StartFromPoses(seeds, seed_poses, init_options.max_relative_scale_sigma, seed_note);
      for (const PoseUpdate& update : estimate.poses) run.poses[original(update.frame_index)] = update.world_from_rig;
      run.init_frame = frames[next - 1]->frame_index;
    }
    for (; next < frames.size(); ++next) {
      const RigFrameObservations* frame = frames[next];
      const FrameEstimate estimate = estimator.AddFrame(reverse_frame(*frame));
      if (estimate.segment > 0) {  // lost: what follows is another world
        run.lost_frame = frame->frame_index;
        for (const ScaleLogEntry& entry : estimator.TakeScaleLog()) {
          if (entry.event == "lost") run.lost_reason = entry.note;
        }
        break;
      }
      for (const PoseUpdate& update : estimate.poses) run.poses[original(update.frame_index)] = update.world_from_rig;
      if (run.init_frame < 0 && estimate.has_pose) run.init_frame = frame->frame_index;
      take(estimator.TakeFinishedKeyframes());
      for (MapLandmark& lm : estimator.TakeFinishedLandmarks()) run.landmarks.push_back(lm);
    }
    take(estimator.Finish());
    for (MapLandmark& lm : estimator.TakeFinishedLandmarks()) run.landmarks.push_back(lm);
    return run;
  }

  // The seeded reverse run: started at the forward poses of the segment's
  // first frames (the forward world and scale), then backwards through the
  // frames before. Applied when it poses at least one of them.
  bool SeededRun(int segment, int first_pose, int previous_posed, ReverseRun* run,
                 ReversePassReport* report) const {
    // The segment's first keyframes, at their final forward poses (the
    // poses a frame got when it was tracked are before the window refined
    // them and before the scale corrections of the turn that follows).
    std::vector<int> seeds;
    for (auto it = kept.lower_bound(first_pose);
         it != kept.end() && static_cast<int>(seeds.size()) < options.window_size; ++it) {
      auto fwd = forward.find(it->first);
      if (fwd == forward.end() || fwd->second.segment != segment) break;
      if (final_keyframes.count(it->first) != 0) seeds.push_back(it->first);
    }
    if (seeds.size() < 2) return false;
    std::vector<const RigFrameObservations*> frames;
    std::vector<Rigid3d> seed_poses;
    for (auto i = seeds.rbegin(); i != seeds.rend(); ++i) {
      frames.push_back(&kept.at(*i));
      seed_poses.push_back(forward.at(*i).world_from_rig);
    }
    for (auto it = kept.lower_bound(first_pose); it != kept.begin();) {
      --it;
      if (it->first <= previous_posed) break;
      frames.push_back(&it->second);
    }
    *run = RunReverse(frames, seed_poses,
                      StrCat("seeded at segment ", segment, "'s poses of frames ", seeds.front(), "-", seeds.back()));
    const bool posed_any = run->poses.lower_bound(previous_posed + 1) != run->poses.lower_bound(first_pose);
    if (!posed_any) return false;
    report->overlap_poses = static_cast<int>(seeds.size());
    report->forward_from_reverse = Sim3d();
    report->seeded = true;
    report->applied = true;
    return true;
  }

  // The unseeded reverse run: its own initialisation, where the scale is
  // observable seen backwards, then aligned to the forward world by a
  // similarity over the frames both posed.
  void AlignedRun(int segment, int first_pose, int previous_posed, ReverseRun* run,
                  ReversePassReport* report) const {
    const int top = first_pose + reverse.overlap_frames;
    std::vector<const RigFrameObservations*> frames;
    for (auto it = kept.upper_bound(top); it != kept.begin();) {
      --it;
      if (it->first <= previous_posed) break;
      frames.push_back(&it->second);
    }
    *run = frames.empty() ? ReverseRun() : RunReverse(frames);
    std::vector<Rigid3d> from, to;
    for (const auto& [index, pose] : run->poses) {
      auto fwd = forward.find(index);
      if (index < first_pose || fwd == forward.end() || fwd->second.segment != segment) continue;
      from.push_back(pose);
      to.push_back(fwd->second.world_from_rig);
    }
    report->overlap_poses = static_cast<int>(from.size());
    if (run->init_frame < 0) {
      report->note = "the reverse pass found no window to initialise in";
    } else if (report->overlap_poses < reverse.min_overlap_poses) {
      report->note = StrCat("the reverse pass shares ", report->overlap_poses, " posed frames with segment ",
                            segment, " (", reverse.min_overlap_poses, " needed to align)");
    } else {
      report->forward_from_reverse = AlignPosesSim3(from, to, &report->align_rms_m);
      const double scale = report->forward_from_reverse.scale;
      if (!(scale >= reverse.min_scale && scale <= reverse.max_scale)) {
        report->note = StrCat("alignment refused: scale ", FormatFixed(scale, 4), " outside [",
                              FormatFixed(reverse.min_scale, 2), ", ", FormatFixed(reverse.max_scale, 2), "]");
        report->forward_from_reverse = Sim3d();
      } else {
        report->applied = true;
      }
    }
  }

  void Complete(int segment, int first_pose, int previous_posed, ReversePassResult* result) const {
    ReversePassReport report;
    report.segment = segment;
    report.first_posed_frame = first_pose;
    report.first_unposed_frame = previous_posed + 1;
    ScaleLogEntry entry;
    entry.segment = segment;
    entry.event = "backfill";
    ReverseRun run;
    std::string seeded_failure;
    // Unposed frames a run posed.
    auto posed = [&](const ReverseRun& r) {
      return static_cast<int>(std::distance(r.poses.upper_bound(previous_posed), r.poses.lower_bound(first_pose)));
    };
    // SeededRun leaves the report untouched when it fails.
    const bool seeded = reverse.seed_from_forward && SeededRun(segment, first_pose, previous_posed, &run, &report);
    if (!seeded) {
      if (reverse.seed_from_forward) {
        seeded_failure = "seeded at the segment's first keyframes it posed no frame before them; ";
      }
      AlignedRun(segment, first_pose, previous_posed, &run, &report);
    } else if (run.lost_frame >= 0) {
      // It lost track on the way: the aligned run, initialised elsewhere,
      // may get further (a marginal frame can fail one run and not the other).
      ReverseRun aligned;
      ReversePassReport aligned_report = report;
      aligned_report.seeded = aligned_report.applied = false;
      aligned_report.overlap_poses = 0;
      AlignedRun(segment, first_pose, previous_posed, &aligned, &aligned_report);
      if (aligned_report.applied && posed(aligned) > posed(run)) {
        seeded_failure = StrCat("seeded at the segment's first keyframes it posed ", posed(run),
                                " frames and lost track at frame ", run.lost_frame, "; ");
        run = std::move(aligned);
        report = aligned_report;
      }
    }
    report.reverse_init_frame = run.init_frame;
    if (!report.applied) report.note = seeded_failure + report.note;

    if (report.applied) {
      const Sim3d& sim = report.forward_from_reverse;
      for (const auto& [index, pose] : run.poses) {
        if (index <= previous_posed || index >= first_pose) continue;
        const RigFrameObservations& frame = kept.at(index);
        result->frames.push_back({index, frame.t_ns, segment, sim.TransformPose(pose)});
        ++report.frames_posed;
        if (report.first_frame_posed < 0) report.first_frame_posed = index;
      }
      for (const KeyframeEstimate& kf : run.keyframes) {
        if (kf.frame_index <= previous_posed || kf.frame_index >= first_pose) continue;
        KeyframeEstimate out = kf;
        out.segment = segment;
        out.world_from_rig = sim.TransformPose(kf.world_from_rig);
        for (Eigen::Vector3d& p : out.observation_points) p = sim * p;
        result->keyframes.push_back(std::move(out));
      }
    }
    if (report.applied && report.frames_posed == 0) {
      // Aligned, but it lost track before reaching any frame without a pose
      // (e.g. images without texture right before the segment): nothing to add.
      report.applied = false;
      report.note = StrCat(seeded_failure, "the reverse pass posed none of the ", first_pose - previous_posed - 1,
                           " frames before frame ", first_pose, " (aligned: Sim3 scale ",
                           FormatFixed(report.forward_from_reverse.scale, 4), ", rms ",
                           FormatFixed(report.align_rms_m, 3), " m over ", report.overlap_poses, " frames)");
      report.forward_from_reverse = Sim3d();
    } else if (report.applied) {
      const Sim3d& sim = report.forward_from_reverse;
      for (const MapLandmark& lm : run.landmarks) result->landmarks.push_back({lm.id, sim * lm.position_world});
      if (report.seeded) {
        report.note = StrCat("frames ", report.first_frame_posed, "-", first_pose - 1, " (", report.frames_posed,
                             " of ", first_pose - previous_posed - 1, ") posed backwards from segment ", segment,
                             "'s final poses of its first ", report.overlap_poses,
                             " keyframes (held fixed), in its world and scale",
                             run.lost_frame >= 0 ? StrCat("; lost at frame ", run.lost_frame, ": ", run.lost_reason)
                                                 : std::string());
      } else {
        report.note = StrCat(seeded_failure, "frames ", report.first_frame_posed, "-", first_pose - 1, " (",
                             report.frames_posed, " of ", first_pose - previous_posed - 1,
                             ") posed backwards from the reverse initialisation at frame ", run.init_frame,
                             ", with the scale of segment ", segment, " applied back (Sim3 scale ",
                             FormatFixed(sim.scale, 4), ", rms ", FormatFixed(report.align_rms_m, 3), " m over ",
                             report.overlap_poses, " frames)");
      }
    }
    entry.frame_index = report.applied ? report.first_frame_posed : first_pose;
    auto first_frame = kept.find(entry.frame_index);
    entry.t_ns = first_frame != kept.end() ? first_frame->second.t_ns : 0;
    entry.applied = report.applied;
    entry.applied_ratio = report.forward_from_reverse.scale;
    entry.note = report.note;
    result->scale_log.push_back(std::move(entry));
    result->reports.push_back(std::move(report));
  }

  ReversePassResult Run() const {
    ReversePassResult result;
    // Segments in the order of their first pose.
    std::vector<std::pair<int, int>> order;  // first posed frame, segment
    for (const auto& [segment, first] : first_posed) order.emplace_back(first, segment);
    std::sort(order.begin(), order.end());
    for (const auto& [first, segment] : order) {
      auto before = forward.lower_bound(first);
      const int previous_posed = before == forward.begin() ? -1 : std::prev(before)->first;
      if (previous_posed + 1 >= first) continue;
      if (kept.lower_bound(previous_posed + 1) == kept.lower_bound(first)) continue;  // nothing kept between
      Complete(segment, first, previous_posed, &result);
    }
    std::sort(result.frames.begin(), result.frames.end(),
              [](const BackfilledFrame& a, const BackfilledFrame& b) { return a.frame_index < b.frame_index; });
    return result;
  }
};

ReversePass::ReversePass(const Rig& rig, const InitializerOptions& init_options, const BackendOptions& options,
                         const ReversePassOptions& reverse_options, int threads)
    : impl_(std::make_unique<Impl>(rig, init_options, options, reverse_options, threads)) {}
ReversePass::~ReversePass() = default;

void ReversePass::Add(const RigFrameObservations& frame, const FrameEstimate& estimate) {
  impl_->Add(frame, estimate);
}

void ReversePass::AddKeyframes(const std::vector<KeyframeEstimate>& keyframes) {
  impl_->AddKeyframes(keyframes);
}

ReversePassResult ReversePass::Run() { return impl_->Run(); }

}  // namespace mcvo
