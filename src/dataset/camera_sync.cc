#include "camera_sync.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::dataset_internal {
namespace {

// Index of the element of sorted `times` nearest to t (the earlier on a tie); -1 when empty.
int64_t Nearest(const std::vector<int64_t>& times, int64_t t) {
  if (times.empty()) return -1;
  const auto it = std::lower_bound(times.begin(), times.end(), t);
  if (it == times.end()) return static_cast<int64_t>(times.size()) - 1;
  const int64_t i = it - times.begin();
  if (i > 0 && t - times[static_cast<size_t>(i - 1)] <= *it - t) return i - 1;
  return i;
}

}  // namespace

SyncResult SynchronizeCameras(const std::vector<CameraImages>& cameras, double tolerance_s,
                              MissingImagePolicy policy) {
  MCVO_CHECK(!cameras.empty());
  const CameraImages& lead = cameras[0];
  const size_t num_frames = lead.t_ns.size();
  const int64_t tolerance_ns = std::llround(tolerance_s * 1e9);
  SyncResult result;
  result.log.push_back(
      StrCat("sync: ", lead.name, " leads (", num_frames, " images); tolerance ", FormatFixed(tolerance_s, 4),
             " s; nearest mutual match; policy ",
             policy == MissingImagePolicy::kSkipFrame ? "skip incomplete frames" : "mark missing cameras"));

  // matches[c][f] = image index of camera c in lead frame f, or -1.
  std::vector<std::vector<int64_t>> matches(cameras.size(), std::vector<int64_t>(num_frames, -1));
  for (size_t f = 0; f < num_frames; ++f) matches[0][f] = static_cast<int64_t>(f);
  for (size_t c = 1; c < cameras.size(); ++c) {
    const CameraImages& camera = cameras[c];
    size_t matched = 0;
    int64_t max_dt = 0;
    for (size_t f = 0; f < num_frames; ++f) {
      const int64_t j = Nearest(camera.t_ns, lead.t_ns[f]);
      if (j < 0) continue;
      const int64_t t = camera.t_ns[static_cast<size_t>(j)];
      const int64_t dt = std::llabs(t - lead.t_ns[f]);
      if (dt > tolerance_ns || Nearest(lead.t_ns, t) != static_cast<int64_t>(f)) continue;
      matches[c][f] = j;
      ++matched;
      max_dt = std::max(max_dt, dt);
    }
    result.log.push_back(StrCat("sync: ", camera.name, ": ", matched, " of ", num_frames,
                                " frames matched (max |dt| ", FormatFixed(max_dt * 1e-6, 3), " ms), ",
                                num_frames - matched, " without an image within tolerance; ",
                                camera.t_ns.size() - matched, " of its ", camera.t_ns.size(),
                                " images matched no ", lead.name, " time"));
  }

  size_t incomplete = 0;
  for (size_t f = 0; f < num_frames; ++f) {
    DatasetFrame frame;
    frame.t_ns = lead.t_ns[f];
    bool complete = true;
    for (size_t c = 0; c < cameras.size(); ++c) {
      const int64_t j = matches[c][f];
      complete = complete && j >= 0;
      frame.images.push_back(j >= 0 ? cameras[c].images[static_cast<size_t>(j)] : std::filesystem::path());
    }
    if (!complete) ++incomplete;
    if (complete || policy == MissingImagePolicy::kMarkMissing) result.frames.push_back(std::move(frame));
  }
  result.log.push_back(
      StrCat("sync: ", result.frames.size(), " frames; ", incomplete, " incomplete frames ",
             policy == MissingImagePolicy::kSkipFrame ? "skipped" : "kept with missing cameras"));
  return result;
}

}  // namespace mcvo::dataset_internal
