#include "mcvo/eval/associate.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

// Frame index of pose i for index association: the stored index, or the
// pose order when the format has none.
int64_t IndexOf(const Trajectory& trajectory, size_t i) {
  return trajectory.has_frame_index ? trajectory.poses[i].frame_index : static_cast<int64_t>(i);
}

std::map<int64_t, size_t> IndexMap(const Trajectory& trajectory, const std::string& name) {
  std::map<int64_t, size_t> by_index;
  for (size_t i = 0; i < trajectory.poses.size(); ++i) {
    const auto [it, inserted] = by_index.emplace(IndexOf(trajectory, i), i);
    if (!inserted) {
      MCVO_THROW_INPUT(name, ": frame index ", it->first, " appears twice (poses ", it->second, " and ", i,
                       "); index association needs unique frame indices");
    }
  }
  return by_index;
}

Association AssociateByIndex(const Trajectory& gt, const Trajectory& est, const std::string& gt_name,
                             const std::string& est_name) {
  const std::map<int64_t, size_t> gt_by_index = IndexMap(gt, gt_name);
  const std::map<int64_t, size_t> est_by_index = IndexMap(est, est_name);
  Association association;
  for (const auto& [index, est_i] : est_by_index) {
    const auto it = gt_by_index.find(index);
    if (it != gt_by_index.end()) association.pairs.push_back({it->second, est_i});
  }
  return association;
}

Association AssociateByTime(const Trajectory& gt, const Trajectory& est, int64_t max_dt_ns) {
  // gt poses sorted by time (stable on index) for the window search.
  std::vector<size_t> gt_order(gt.poses.size());
  for (size_t i = 0; i < gt_order.size(); ++i) gt_order[i] = i;
  std::stable_sort(gt_order.begin(), gt_order.end(),
                   [&gt](size_t a, size_t b) { return gt.poses[a].t_ns < gt.poses[b].t_ns; });

  struct Candidate {
    int64_t abs_dt_ns;
    size_t est_index;
    size_t gt_index;
  };
  std::vector<Candidate> candidates;
  for (size_t j = 0; j < est.poses.size(); ++j) {
    const int64_t t = est.poses[j].t_ns;
    auto it = std::lower_bound(gt_order.begin(), gt_order.end(), t - max_dt_ns,
                               [&gt](size_t i, int64_t value) { return gt.poses[i].t_ns < value; });
    for (; it != gt_order.end() && gt.poses[*it].t_ns <= t + max_dt_ns; ++it) {
      const int64_t dt = gt.poses[*it].t_ns - t;
      candidates.push_back({dt < 0 ? -dt : dt, j, *it});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.abs_dt_ns, a.est_index, a.gt_index) < std::tie(b.abs_dt_ns, b.est_index, b.gt_index);
  });

  std::vector<bool> gt_used(gt.poses.size(), false);
  std::vector<bool> est_used(est.poses.size(), false);
  Association association;
  for (const Candidate& c : candidates) {
    if (gt_used[c.gt_index] || est_used[c.est_index]) continue;
    gt_used[c.gt_index] = true;
    est_used[c.est_index] = true;
    association.pairs.push_back({c.gt_index, c.est_index});
    association.max_abs_dt_ns = std::max(association.max_abs_dt_ns, c.abs_dt_ns);
  }
  std::sort(association.pairs.begin(), association.pairs.end(),
            [](const PosePair& a, const PosePair& b) { return a.est_index < b.est_index; });
  return association;
}

}  // namespace

std::optional<AssociationMode> AssociationModeFromName(std::string_view name) {
  if (name == "time") return AssociationMode::kTime;
  if (name == "index") return AssociationMode::kIndex;
  return std::nullopt;
}

std::string_view AssociationModeName(AssociationMode mode) {
  return mode == AssociationMode::kTime ? "time" : "index";
}

void AssociationOptions::Check() const {
  if (!std::isfinite(max_dt_s) || max_dt_s < 0.0 || max_dt_s > 1e6) {
    throw UsageError(StrCat("max_dt_s: expected a time in [0, 1e6] s, got ", FormatDouble(max_dt_s)));
  }
}

int64_t AssociationOptions::MaxDtNs() const { return std::llround(max_dt_s * 1e9); }

Association AssociatePoses(const Trajectory& gt, const Trajectory& est, const AssociationOptions& options,
                           const std::string& gt_name, const std::string& est_name) {
  options.Check();
  Association association;
  if (options.mode == AssociationMode::kTime) {
    if (!gt.has_time) {
      MCVO_THROW_INPUT(gt_name, ": has no time stamps; use index association or give a times file");
    }
    if (!est.has_time) {
      MCVO_THROW_INPUT(est_name, ": has no time stamps; use index association or give a times file");
    }
    association = AssociateByTime(gt, est, options.MaxDtNs());
  } else {
    association = AssociateByIndex(gt, est, gt_name, est_name);
  }
  association.num_gt_unmatched = gt.poses.size() - association.pairs.size();
  association.num_est_unmatched = est.poses.size() - association.pairs.size();
  return association;
}

}  // namespace mcvo
