// Cross-camera links across time (loop/cross_camera_links.h).
#include "mcvo/loop/cross_camera_links.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <unordered_map>
#include <utility>

#include <Eigen/LU>
#include <opencv2/core/hal/hal.hpp>

#include "mcvo/dataset/overlap.h"
#include "mcvo/util/option_checks.h"
#include "mcvo/util/parallel.h"

namespace mcvo {
namespace {

constexpr double kFocalPx = 460.0;  // radius_px is "at focal 460", as the loop closer's thresholds

// The observation of a landmark by another camera that lends its descriptor.
struct Source {
  const LinkKeyframe* keyframe = nullptr;
  int row = 0;
  double cos_view = -2.0;  // between its ray and the target camera's ray to the point
};

// One observation of a landmark as a ray in the world. Its centre under a
// scale hypothesis s about the rig's origin at keyframe j (c_j) is
// c_j + s (rig_origin - c_j) + offset: the rig's motion scales, its
// extrinsics do not.
struct Ray {
  Eigen::Vector3d rig_origin, offset, direction;  // direction unit
  Eigen::Vector3d Centre(const Eigen::Vector3d& c_j, double s) const {
    return c_j + s * (rig_origin - c_j) + offset;
  }
};

struct Proposal {
  int64_t source_id = 0;
  int64_t target_id = 0;
  int distance = 0;
  double scale = 1.0;
  const Source* source = nullptr;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // the target's
};

// b's own landmark observations at keyframe j (a landmark has a row per
// descriptor level in the loop closer's rows, one here).
struct TargetRows {
  std::vector<int64_t> landmark_id;
  std::vector<Eigen::Vector2d> pixel;
  std::vector<const uchar*> descriptor;
  std::vector<Eigen::Vector3d> bearings;  // in camera b, unit
  std::set<int64_t> seen;
};

// Angle between unit vector t and the polyline through unit vectors `path`
// (chords: the path spans a few degrees), in radians.
double AngleToPath(const Eigen::Vector3d& t, const std::vector<Eigen::Vector3d>& path) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector3d d = path[i + 1] - path[i];
    const double length2 = d.squaredNorm();
    const double u = length2 > 0.0 ? std::clamp((t - path[i]).dot(d) / length2, 0.0, 1.0) : 0.0;
    const Eigen::Vector3d closest = (path[i] + u * d).normalized();
    best = std::min(best, std::atan2(t.cross(closest).norm(), t.dot(closest)));
  }
  if (path.size() == 1) best = std::atan2(t.cross(path[0]).norm(), t.dot(path[0]));
  return best;
}

class LinkSearch {
 public:
  LinkSearch(const Rig& rig, const std::vector<LinkKeyframe>& keyframes,
             const CrossCameraLinkOptions& options, const std::vector<std::pair<int, int>>& overlapping)
      : rig_(rig),
        keyframes_(keyframes),
        options_(options),
        cos_view_(std::cos(options.max_view_angle_deg * M_PI / 180.0)),
        radius_rad_(options.radius_px / kFocalPx),
        cos_parallax_(std::cos(options.min_parallax_deg * M_PI / 180.0)) {
    for (const Camera& camera : rig.cameras) {
      cam_from_rig_.push_back(camera.cam_from_rig);
      centre_in_rig_.push_back(camera.cam_from_rig.Inverse().translation);
    }
    const size_t n = static_cast<size_t>(rig.NumCameras());
    linked_.assign(n * n, true);
    for (size_t a = 0; a < n; ++a) linked_[a * n + a] = false;
    if (!options.overlapping_pairs) {
      for (const auto& [a, b] : overlapping) {
        if (a < 0 || b < 0 || static_cast<size_t>(a) >= n || static_cast<size_t>(b) >= n) continue;
        linked_[static_cast<size_t>(a) * n + static_cast<size_t>(b)] = false;
        linked_[static_cast<size_t>(b) * n + static_cast<size_t>(a)] = false;
      }
    }
    if (options.max_pair_overlap < 1.0) {
      for (size_t a = 0; a < n; ++a) {
        for (size_t b = a + 1; b < n; ++b) {
          const Camera &ca = rig.cameras[a], &cb = rig.cameras[b];
          const double mutual =
              std::min(ViewOverlap(ca, cb, kViewOverlapDepthM), ViewOverlap(cb, ca, kViewOverlapDepthM));
          if (mutual > options.max_pair_overlap) linked_[a * n + b] = linked_[b * n + a] = false;
        }
      }
    }
    // The scale hypotheses, nearest to 1 first (ties in the error go to it).
    const int steps = static_cast<int>(std::lround(options.max_scale_error / kScaleStep));
    scales_.push_back(1.0);
    for (int i = 1; i <= steps; ++i) {
      scales_.push_back(1.0 - i * kScaleStep);
      scales_.push_back(1.0 + i * kScaleStep);
    }
    // Every landmark's observations as rays (once per keyframe and camera:
    // a landmark has a row per descriptor level).
    for (const LinkKeyframe& kf : keyframes) {
      for (size_t r = 0; r < kf.camera.size(); ++r) {
        const size_t c = static_cast<size_t>(kf.camera[r]);
        const std::optional<Eigen::Vector3d> bearing = rig.cameras[c].Unproject(kf.pixel[r]);
        if (!bearing) continue;
        std::vector<Ray>& rays = rays_[kf.landmark_id[r]];
        const Eigen::Vector3d offset = kf.world_from_rig.rotation * centre_in_rig_[c];
        if (!rays.empty() && rays.back().rig_origin == kf.world_from_rig.translation &&
            rays.back().offset == offset) {
          continue;
        }
        const Eigen::Vector3d direction =
            kf.world_from_rig.rotation * (cam_from_rig_[c].rotation.conjugate() * *bearing);
        rays.push_back({kf.world_from_rig.translation, offset, direction.normalized()});
      }
    }
  }

  // The links found at keyframe j, camera by camera.
  std::vector<CrossCameraLink> At(int j) const {
    std::vector<CrossCameraLink> links;
    for (int b = 0; b < rig_.NumCameras(); ++b) AtCamera(j, b, &links);
    return links;
  }

 private:
  static constexpr double kScaleStep = 0.01;

  // A track whose rays span at least min_parallax_deg: its own depth is
  // known, so that the joint test can tell it from another point in line.
  bool HasParallax(const std::vector<Ray>& rays) const {
    for (size_t a = 0; a < rays.size(); ++a) {
      for (size_t b = a + 1; b < rays.size(); ++b) {
        if (rays[a].direction.dot(rays[b].direction) <= cos_parallax_) return true;
      }
    }
    return false;
  }

  const std::vector<Ray>& RaysOf(int64_t id) const {
    static const std::vector<Ray> kNone;
    const auto it = rays_.find(id);
    return it != rays_.end() ? it->second : kNone;
  }

  // The scale hypothesis under which the rays of both landmarks meet best:
  // (scale, the largest angle of a ray to their midpoint, as pixels at
  // focal 460); the error is infinite when none has the point in front of
  // every ray.
  std::pair<double, double> JointError(const std::vector<Ray>& a, const std::vector<Ray>& b,
                                       const Eigen::Vector3d& c_j) const {
    std::pair<double, double> best{1.0, std::numeric_limits<double>::infinity()};
    std::vector<const Ray*> rays;
    for (const Ray& r : a) rays.push_back(&r);
    for (const Ray& r : b) rays.push_back(&r);
    for (double s : scales_) {
      Eigen::Matrix3d lhs = Eigen::Matrix3d::Zero();
      Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
      for (const Ray* r : rays) {
        const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - r->direction * r->direction.transpose();
        lhs += p;
        rhs += p * r->Centre(c_j, s);
      }
      const Eigen::FullPivLU<Eigen::Matrix3d> lu(lhs);
      if (!lu.isInvertible()) continue;
      const Eigen::Vector3d point = lu.solve(rhs);
      double worst = 0.0;
      for (const Ray* r : rays) {
        const Eigen::Vector3d to_point = point - r->Centre(c_j, s);
        const double dot = to_point.dot(r->direction);
        if (!(dot > 0.0)) {
          worst = std::numeric_limits<double>::infinity();
          break;
        }
        worst = std::max(worst, std::atan2(to_point.cross(r->direction).norm(), dot) * kFocalPx);
      }
      if (worst < best.second) best = {s, worst};
    }
    return best;
  }

  TargetRows Targets(const LinkKeyframe& target, int b) const {
    TargetRows out;
    const Camera& camera = rig_.cameras[static_cast<size_t>(b)];
    const auto add = [&](int64_t id, const Eigen::Vector2d& pixel, const uchar* descriptor) {
      const std::optional<Eigen::Vector3d> bearing = camera.Unproject(pixel);
      if (!bearing) return;
      out.landmark_id.push_back(id);
      out.pixel.push_back(pixel);
      out.descriptor.push_back(descriptor);
      out.bearings.push_back(bearing->normalized());
    };
    for (size_t r = 0; r < target.camera.size(); ++r) {
      if (target.camera[r] != b) continue;
      out.seen.insert(target.landmark_id[r]);
      add(target.landmark_id[r], target.pixel[r], target.descriptors.ptr<uchar>(static_cast<int>(r)));
    }
    return out;
  }

  // Landmark `id` (from `source`) matched among b's observations at j: the
  // proposal, if one passes (header: radius, descriptor, joint rays).
  std::optional<Proposal> Match(int64_t id, const Source& source, const LinkKeyframe& target, int b,
                                const TargetRows& targets) const {
    const Camera& camera = rig_.cameras[static_cast<size_t>(b)];
    const Rigid3d cam_from_world = cam_from_rig_[static_cast<size_t>(b)] * target.world_from_rig.Inverse();
    const Eigen::Vector3d& c_j = target.world_from_rig.translation;
    const LinkKeyframe& from = *source.keyframe;
    const size_t row = static_cast<size_t>(source.row);
    const Eigen::Vector3d offset =
        from.world_from_rig.rotation * centre_in_rig_[static_cast<size_t>(from.camera[row])];
    // Where b sees L's point under the scale hypotheses at both ends and 1:
    // moved with the rig's motion, not with the extrinsics.
    std::vector<Eigen::Vector3d> path;
    for (double s : {1.0 - options_.max_scale_error, 1.0, 1.0 + options_.max_scale_error}) {
      const Eigen::Vector3d point = c_j + s * (from.point_in_world[row] - offset - c_j) + offset;
      const Eigen::Vector3d in_cam = cam_from_world * point;
      const std::optional<Eigen::Vector2d> pixel = camera.Project(in_cam);
      if (!pixel || !camera.IsInImage(*pixel)) return std::nullopt;
      path.push_back(in_cam.normalized());
    }
    const uchar* descriptor = from.descriptors.ptr<uchar>(source.row);
    std::map<int64_t, int> distance;      // target landmark -> nearest of its rows
    std::map<int64_t, size_t> first_row;  // landmark -> its first target row
    // Cheap test first: within the radius of the path is within radius +
    // the path's half-length of its middle.
    const double reach = radius_rad_ + std::max(std::acos(std::clamp(path[0].dot(path[1]), -1.0, 1.0)),
                                                std::acos(std::clamp(path[2].dot(path[1]), -1.0, 1.0)));
    const double cos_reach = std::cos(std::min(reach, M_PI));
    for (size_t t = 0; t < targets.landmark_id.size(); ++t) {
      if (targets.bearings[t].dot(path[1]) < cos_reach) continue;
      if (AngleToPath(targets.bearings[t], path) > radius_rad_) continue;
      const int d = cv::hal::normHamming(descriptor, targets.descriptor[t], from.descriptors.cols);
      const auto [it, inserted] = distance.emplace(targets.landmark_id[t], d);
      if (!inserted) it->second = std::min(it->second, d);
      first_row.emplace(targets.landmark_id[t], t);
    }
    int best = -1, second = -1;
    int64_t best_id = 0;
    for (const auto& [target_id, d] : distance) {
      if (best < 0 || d < best) {
        second = best;
        best = d;
        best_id = target_id;
      } else if (second < 0 || d < second) {
        second = d;
      }
    }
    if (best < 0 || best > options_.max_distance) return std::nullopt;
    if (second >= 0 && !(best < options_.ratio * second)) return std::nullopt;
    if (!HasParallax(RaysOf(id)) || !HasParallax(RaysOf(best_id))) return std::nullopt;
    const auto [scale, error] = JointError(RaysOf(id), RaysOf(best_id), c_j);
    if (!(error <= options_.max_reprojection_px)) return std::nullopt;
    return Proposal{id, best_id, best, scale, &source, targets.pixel[first_row.at(best_id)]};
  }

  void AtCamera(int j, int b, std::vector<CrossCameraLink>* links) const {
    const LinkKeyframe& target = keyframes_[static_cast<size_t>(j)];
    const TargetRows targets = Targets(target, b);
    if (targets.landmark_id.empty()) return;
    const Eigen::Vector3d centre = target.world_from_rig * centre_in_rig_[static_cast<size_t>(b)];
    const std::unordered_map<int64_t, Source> sources = Sources(j, b, centre, targets.seen);
    std::vector<Proposal> proposals;
    // (Proposals in any order: the mutual-best choice below does not depend on it.)
    for (const auto& [id, source] : sources) {
      if (std::optional<Proposal> p = Match(id, source, target, b, targets)) proposals.push_back(*p);
    }
    // Mutual best: each target landmark keeps its nearest source, unless tied.
    std::map<int64_t, std::pair<const Proposal*, bool>> nearest;  // target -> (proposal, unique)
    for (const Proposal& p : proposals) {
      const auto [it, inserted] = nearest.emplace(p.target_id, std::make_pair(&p, true));
      if (inserted) continue;
      if (p.distance < it->second.first->distance) {
        it->second = {&p, true};
      } else if (p.distance == it->second.first->distance) {
        it->second.second = false;
      }
    }
    for (const auto& [target_id, entry] : nearest) {
      if (!entry.second) continue;
      const Proposal& p = *entry.first;
      CrossCameraLink link;
      link.keyframe = j;
      link.frame_index = target.frame_index;
      link.camera = b;
      link.landmark_id = target_id;
      link.pixel = p.pixel;
      const LinkKeyframe& from = *p.source->keyframe;
      link.source_keyframe = static_cast<int>(&from - keyframes_.data());
      link.source_frame_index = from.frame_index;
      link.source_camera = from.camera[static_cast<size_t>(p.source->row)];
      link.source_pixel = from.pixel[static_cast<size_t>(p.source->row)];
      link.source_landmark_id = p.source_id;
      link.distance = p.distance;
      link.view_angle_deg = std::acos(std::clamp(p.source->cos_view, -1.0, 1.0)) * 180.0 / M_PI;
      link.scale = p.scale;
      links->push_back(link);
    }
  }

  // Landmarks the other cameras observe in the window around j that b does
  // not see at j, each with the observation whose ray is nearest to b's.
  // Only observations within max_view_angle_deg of b's ray count.
  std::unordered_map<int64_t, Source> Sources(int j, int b, const Eigen::Vector3d& centre,
                                              const std::set<int64_t>& seen) const {
    std::unordered_map<int64_t, Source> sources;
    const int n = static_cast<int>(keyframes_.size());
    for (int k = std::max(0, j - options_.window_keyframes);
         k <= std::min(n - 1, j + options_.window_keyframes); ++k) {
      const LinkKeyframe& kf = keyframes_[static_cast<size_t>(k)];
      for (size_t r = 0; r < kf.camera.size(); ++r) {
        const int c = kf.camera[r];
        if (!linked_[static_cast<size_t>(c) * rig_.cameras.size() + static_cast<size_t>(b)]) continue;
        const Eigen::Vector3d& point = kf.point_in_world[r];
        const Eigen::Vector3d from_target = point - centre;
        const Eigen::Vector3d from_source =
            point - kf.world_from_rig * centre_in_rig_[static_cast<size_t>(c)];
        const double norms = from_target.norm() * from_source.norm();
        if (!(norms > 0.0)) continue;
        const double cos_view = from_target.dot(from_source) / norms;
        if (cos_view < cos_view_ || seen.count(kf.landmark_id[r]) != 0) continue;
        Source& s = sources[kf.landmark_id[r]];
        if (cos_view > s.cos_view) s = {&kf, static_cast<int>(r), cos_view};
      }
    }
    return sources;
  }

  const Rig& rig_;
  const std::vector<LinkKeyframe>& keyframes_;
  const CrossCameraLinkOptions options_;
  const double cos_view_, radius_rad_, cos_parallax_;
  std::vector<Rigid3d> cam_from_rig_;
  std::vector<Eigen::Vector3d> centre_in_rig_;
  std::vector<double> scales_;
  std::vector<bool> linked_;                  // camera a * n + b: look for a's landmarks in b
  std::map<int64_t, std::vector<Ray>> rays_;  // per landmark
};

}  // namespace

void CrossCameraLinkOptions::Check() const {
  CheckAtLeast("/loop/cross_camera/window_keyframes", window_keyframes, 0);
  CheckPositive("/loop/cross_camera/radius_px", radius_px);
  CheckAtLeast("/loop/cross_camera/max_distance", max_distance, 0);
  CheckInRange("/loop/cross_camera/ratio", ratio, 0.0, 1.0);
  CheckInRange("/loop/cross_camera/max_scale_error", max_scale_error, 0.0, 0.5);
  CheckPositive("/loop/cross_camera/max_reprojection_px", max_reprojection_px);
  CheckInRange("/loop/cross_camera/min_parallax_deg", min_parallax_deg, 0.0, 90.0);
  CheckInRange("/loop/cross_camera/max_view_angle_deg", max_view_angle_deg, 0.0, 180.0);
  CheckInRange("/loop/cross_camera/max_pair_overlap", max_pair_overlap, 0.0, 1.0);
}

std::vector<CrossCameraLink> FindCrossCameraLinks(const Rig& rig, const std::vector<LinkKeyframe>& keyframes,
                                                  const CrossCameraLinkOptions& options, int threads,
                                                  const std::vector<std::pair<int, int>>& overlapping) {
  options.Check();
  std::vector<CrossCameraLink> links;
  if (options.window_keyframes <= 0 || rig.NumCameras() < 2) return links;
  const LinkSearch search(rig, keyframes, options, overlapping);
  std::vector<std::vector<CrossCameraLink>> per_keyframe(keyframes.size());
  ParallelFor(static_cast<int>(keyframes.size()), threads,
              [&](int j) { per_keyframe[static_cast<size_t>(j)] = search.At(j); });
  // Each pair of landmarks once, where it was first found.
  std::set<std::pair<int64_t, int64_t>> reported;
  for (const std::vector<CrossCameraLink>& found : per_keyframe) {
    for (const CrossCameraLink& link : found) {
      const auto pair = std::minmax(link.landmark_id, link.source_landmark_id);
      if (reported.emplace(pair.first, pair.second).second) links.push_back(link);
    }
  }
  return links;
}

}  // namespace mcvo
