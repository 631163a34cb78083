// Synthetic feature tracks of a rig driving through random static landmarks:
// the estimator's input (RigFrameObservations: per camera pixels and unit
// bearings with stable feature ids, plus cross-camera observations) with the
// ground truth next to it. Header only, for the initializer and back-end
// tests and the initializer benchmark; no images are rendered.
//
//   const Rig rig = LoadPresetRig("kitti360_3cam");
//   const auto world_from_rig = TurningTrajectory(30, 0.6, 2.5);   // 30 frames, 0.6 m and 2.5 deg per frame
//   const auto landmarks = LandmarksAroundPath(world_from_rig, LandmarkOptions());
//   TrackOptions options;
//   options.pixel_noise_px = 1.0;
//   const SyntheticRigTracks tracks = MakeRigTracks(rig, world_from_rig, landmarks, options);
//
// Conventions: world z up, ground at z = 0; the rig frame is the KITTI-360
// vehicle frame of config/rigs/*.json: x forward, y right, z down. Headings
// are counter-clockwise from world x (a positive turn is a left turn).
//
// Determinism: every random number is a hash of (seed, purpose, indices)
// (util/hash.h): the same inputs give the same tracks on every platform and
// standard library (no std::*_distribution), whatever order things are
// generated in. Gaussian noise: Box-Muller on those hashes.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/initializer/camera_sfm.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/map/observations.h"
#include "mcvo/util/hash.h"

namespace mcvo::testing {

inline constexpr double kSynthPi = 3.14159265358979323846;
inline constexpr double kSynthDeg = kSynthPi / 180.0;

#ifdef MCVO_SOURCE_DIR
// A preset of config/rigs/ by name: kitti360, kitti360_3cam, kitti360_stereo, irregular5, multicam6.
inline Rig LoadPresetRig(const std::string& name) {
  return ReadRig(std::string(MCVO_SOURCE_DIR) + "/config/rigs/" + name + ".json");
}
#endif

// ---------------------------------------------------------------------------
// Trajectories

// world_from_rig rotation of a vehicle with heading `yaw` (about world z),
// pitch (nose up positive) and roll (right side down positive).
inline Eigen::Matrix3d WorldFromRigRotation(double yaw, double pitch = 0.0, double roll = 0.0) {
  // Vehicle frame FLU (x forward, y left, z up); rig frame FRD = FLU * diag(1, -1, -1).
  const Eigen::Matrix3d world_from_flu = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                          Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()) *
                                          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                             .toRotationMatrix();
  return world_from_flu * Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
}

struct DriveSpec {
  int num_frames = 30;
  double step_m = 0.8;              // distance driven per frame (8 m/s at 10 Hz)
  int straight_frames = 0;          // frames driven straight before the turn
  double turn_deg_per_frame = 0.0;  // heading change per frame once turning (+: left)
  int turn_frames = -1;             // frames of turning, then straight again; -1: to the end
  double start_heading_deg = 0.0;
  double height_m = 1.7;  // rig origin above the ground
  // Small oscillations (amplitudes, deg): body pitch/roll, and a slow heading
  // weave (lane keeping) that makes a straight drive only near-pure translation.
  double pitch_roll_wobble_deg = 0.0;
  double yaw_wobble_deg = 0.0;
};

// world_from_rig per frame of a car-like drive: heading changes by the turn
// rate, the position follows the chord of each arc (exact for constant
// curvature, up to the chord/arc length difference).
inline std::vector<Rigid3d> DriveTrajectory(const DriveSpec& spec) {
  std::vector<Rigid3d> world_from_rig;
  world_from_rig.reserve(static_cast<size_t>(std::max(spec.num_frames, 0)));
  auto heading_at = [&](int k) {
    int turning = std::max(0, k - spec.straight_frames);
    if (spec.turn_frames >= 0) turning = std::min(turning, spec.turn_frames);
    return spec.start_heading_deg * kSynthDeg + turning * spec.turn_deg_per_frame * kSynthDeg;
  };
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  for (int k = 0; k < spec.num_frames; ++k) {
    const double weave = spec.yaw_wobble_deg * kSynthDeg * std::sin(0.37 * k);
    const double pitch = spec.pitch_roll_wobble_deg * kSynthDeg * std::sin(0.9 * k + 0.3);
    const double roll = spec.pitch_roll_wobble_deg * kSynthDeg * std::cos(0.6 * k);
    const Eigen::Matrix3d rotation = WorldFromRigRotation(heading_at(k) + weave, pitch, roll);
    world_from_rig.emplace_back(rotation, Eigen::Vector3d(position.x(), position.y(), spec.height_m));
    const double chord_heading = 0.5 * (heading_at(k) + heading_at(k + 1));
    position += spec.step_m * Eigen::Vector2d(std::cos(chord_heading), std::sin(chord_heading));
  }
  return world_from_rig;
}

// A drive of several legs: each leg drives `frames` frames turning at
// `deg_per_frame` (0: straight), with DriveSpec's step, height and wobbles
// (its turn fields are ignored). For routes with several corners.
struct DriveLeg {
  int frames = 0;
  double deg_per_frame = 0.0;
};
inline std::vector<Rigid3d> LegsTrajectory(const DriveSpec& spec, const std::vector<DriveLeg>& legs) {
  std::vector<double> heading{spec.start_heading_deg * kSynthDeg};
  for (const DriveLeg& leg : legs) {
    for (int k = 0; k < leg.frames; ++k) heading.push_back(heading.back() + leg.deg_per_frame * kSynthDeg);
  }
  std::vector<Rigid3d> world_from_rig;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  for (size_t k = 0; k + 1 < heading.size(); ++k) {
    const double weave = spec.yaw_wobble_deg * kSynthDeg * std::sin(0.37 * static_cast<double>(k));
    const double pitch =
        spec.pitch_roll_wobble_deg * kSynthDeg * std::sin(0.9 * static_cast<double>(k) + 0.3);
    const double roll = spec.pitch_roll_wobble_deg * kSynthDeg * std::cos(0.6 * static_cast<double>(k));
    world_from_rig.emplace_back(WorldFromRigRotation(heading[k] + weave, pitch, roll),
                                Eigen::Vector3d(position.x(), position.y(), spec.height_m));
    const double chord_heading = 0.5 * (heading[k] + heading[k + 1]);
    position += spec.step_m * Eigen::Vector2d(std::cos(chord_heading), std::sin(chord_heading));
  }
  return world_from_rig;
}

// Pure translation along world x.
inline std::vector<Rigid3d> StraightTrajectory(int num_frames, double step_m = 0.8) {
  DriveSpec spec;
  spec.num_frames = num_frames;
  spec.step_m = step_m;
  return DriveTrajectory(spec);
}

// Turning from the first frame (after `straight_frames`) at a constant rate;
// radius = step_m / (deg_per_frame in rad): 0.6 m and 3 deg per frame is a
// 11.5 m radius at 6 m/s (10 Hz), a city corner.
inline std::vector<Rigid3d> TurningTrajectory(int num_frames, double step_m, double turn_deg_per_frame,
                                              int straight_frames = 0) {
  DriveSpec spec;
  spec.num_frames = num_frames;
  spec.step_m = step_m;
  spec.turn_deg_per_frame = turn_deg_per_frame;
  spec.straight_frames = straight_frames;
  spec.pitch_roll_wobble_deg = 0.3;
  return DriveTrajectory(spec);
}

// ---------------------------------------------------------------------------
// Landmarks

struct LandmarkOptions {
  uint64_t seed = 1;
  double per_metre = 60.0;  // landmarks per metre of path (margins included)
  double margin_m = 45.0;   // the path is extended this far before the start and after the end
  // Mixture: facades on both sides, the ground, and clutter (poles, trees, cars).
  double facade_fraction = 0.45;
  double ground_fraction = 0.35;  // the rest is clutter
  double facade_min_offset_m = 6.0;
  double facade_max_offset_m = 14.0;
  double facade_max_height_m = 12.0;
  double ground_max_offset_m = 20.0;
  double clutter_max_offset_m = 25.0;
  double clutter_max_height_m = 5.0;
};

// Random static points along the ground track of the trajectory (polyline of
// its positions, extended by margin_m along the first and last headings).
inline std::vector<Eigen::Vector3d> LandmarksAroundPath(const std::vector<Rigid3d>& world_from_rig,
                                                        const LandmarkOptions& options) {
  std::vector<Eigen::Vector2d> path;
  std::vector<Eigen::Vector2d> tangent;  // unit, per path vertex
  if (world_from_rig.empty()) return {};
  auto heading_of = [](const Rigid3d& pose) {
    const Eigen::Vector3d forward = pose.rotation * Eigen::Vector3d::UnitX();
    Eigen::Vector2d t(forward.x(), forward.y());
    return t.norm() > 1e-9 ? Eigen::Vector2d(t.normalized()) : Eigen::Vector2d(1.0, 0.0);
  };
  const Eigen::Vector2d first = world_from_rig.front().translation.head<2>();
  const Eigen::Vector2d last = world_from_rig.back().translation.head<2>();
  path.push_back(first - options.margin_m * heading_of(world_from_rig.front()));
  tangent.push_back(heading_of(world_from_rig.front()));
  for (const Rigid3d& pose : world_from_rig) {
    const Eigen::Vector2d p = pose.translation.head<2>();
    if ((p - path.back()).norm() < 1e-6) continue;
    path.push_back(p);
    tangent.push_back(heading_of(pose));
  }
  path.push_back(last + options.margin_m * heading_of(world_from_rig.back()));
  tangent.push_back(heading_of(world_from_rig.back()));
  std::vector<double> arc(path.size(), 0.0);
  for (size_t i = 1; i < path.size(); ++i) arc[i] = arc[i - 1] + (path[i] - path[i - 1]).norm();
  const double length = arc.back();
  const int count = static_cast<int>(std::ceil(options.per_metre * length));

  std::vector<Eigen::Vector3d> landmarks;
  landmarks.reserve(static_cast<size_t>(count));
  SplitMix64Rng rng(HashWords({options.seed, 0x4C414E44ULL}));  // "LAND"
  for (int n = 0; n < count; ++n) {
    const double s = rng.Uniform(0.0, length);
    const size_t i = static_cast<size_t>(
        std::min<std::ptrdiff_t>(std::upper_bound(arc.begin(), arc.end(), s) - arc.begin(),
                                 static_cast<std::ptrdiff_t>(arc.size()) - 1));
    const size_t i0 = i - 1;
    const double u = arc[i] > arc[i0] ? (s - arc[i0]) / (arc[i] - arc[i0]) : 0.0;
    const Eigen::Vector2d centre = path[i0] + u * (path[i] - path[i0]);
    const Eigen::Vector2d forward = (tangent[i0] + u * (tangent[i] - tangent[i0])).normalized();
    const Eigen::Vector2d left(-forward.y(), forward.x());
    const double kind = rng.Uniform(0.0, 1.0);
    const double along = rng.Uniform(-2.0, 2.0);
    double lateral = 0.0, height = 0.0;
    if (kind < options.facade_fraction) {
      const double side = rng.Bernoulli(0.5) ? 1.0 : -1.0;
      lateral = side * rng.Uniform(options.facade_min_offset_m, options.facade_max_offset_m);
      height = rng.Uniform(0.3, options.facade_max_height_m);
    } else if (kind < options.facade_fraction + options.ground_fraction) {
      lateral = rng.Uniform(-options.ground_max_offset_m, options.ground_max_offset_m);
      height = 0.0;
    } else {
      do {
        lateral = rng.Uniform(-options.clutter_max_offset_m, options.clutter_max_offset_m);
      } while (std::abs(lateral) < 2.5);
      height = rng.Uniform(0.2, options.clutter_max_height_m);
    }
    const Eigen::Vector2d xy = centre + along * forward + lateral * left;
    landmarks.emplace_back(xy.x(), xy.y(), height);
  }
  return landmarks;
}

// ---------------------------------------------------------------------------
// Tracks

struct TrackOptions {
  uint64_t seed = 1;
  double pixel_noise_px = 0.0;        // Gaussian, per pixel coordinate, per observation
  int max_features_per_camera = 150;  // tracked features per camera and frame
  bool cross_camera = true;           // report features of one camera seen by another
  double min_range_m = 1.0;           // visible: distance from the camera centre in range,
  double max_range_m = 40.0;          //   in the model's domain and inside the image
  // Bad tracks (LK drift, mismatches): this fraction of new tracks gets, in
  // every frame, an extra offset of outlier_px in a random direction.
  double outlier_fraction = 0.0;
  double outlier_px = 10.0;
  int first_frame_index = 0;
  int64_t t0_ns = 0;
  int64_t frame_period_ns = 100000000;  // 10 Hz
};

struct FeatureTruth {
  int camera = 0;    // the camera that tracks the feature
  int landmark = 0;  // index into SyntheticRigTracks::landmarks
  bool outlier = false;
};

struct SyntheticRigTracks {
  std::vector<RigFrameObservations> frames;
  std::vector<Rigid3d> world_from_rig;        // ground truth, one per frame
  std::vector<Eigen::Vector3d> landmarks;     // world
  std::map<uint64_t, FeatureTruth> features;  // by feature id
  int num_cross_camera = 0;                   // cross-camera observations over all frames
};

// Standard normal pair from two hashes (Box-Muller).
inline Eigen::Vector2d GaussianPairFromHash(uint64_t h) {
  const double u1 = OpenUnitFromHash(SplitMix64(h ^ 0x9E3779B97F4A7C15ULL));
  const double u2 = UnitFromHash(SplitMix64(h + 0x632BE59BD9B4E019ULL));
  const double radius = std::sqrt(-2.0 * std::log(u1));
  return radius * Eigen::Vector2d(std::cos(2.0 * kSynthPi * u2), std::sin(2.0 * kSynthPi * u2));
}

// Pixel of the landmark in the camera when visible (noise free).
inline std::optional<Eigen::Vector2d> VisiblePixel(const Camera& camera, const Rigid3d& cam_from_world,
                                                   const Eigen::Vector3d& point_in_world,
                                                   const TrackOptions& options) {
  const Eigen::Vector3d p = cam_from_world * point_in_world;
  const double range = p.norm();
  if (range < options.min_range_m || range > options.max_range_m) return std::nullopt;
  const std::optional<Eigen::Vector2d> pixel = camera.Project(p);
  if (!pixel || !camera.IsInImage(*pixel)) return std::nullopt;
  return pixel;
}

inline SyntheticRigTracks MakeRigTracks(const Rig& rig, const std::vector<Rigid3d>& world_from_rig,
                                        const std::vector<Eigen::Vector3d>& landmarks,
                                        const TrackOptions& options) {
  const int num_cameras = rig.NumCameras();
  SyntheticRigTracks out;
  out.world_from_rig = world_from_rig;
  out.landmarks = landmarks;
  // Active tracks per camera: landmark -> feature id.
  std::vector<std::map<int, uint64_t>> active(static_cast<size_t>(num_cameras));
  uint64_t next_id = 1;

  // Noisy observation of a feature (tag separates the feature's own camera
  // from cross-camera sightings). std::nullopt when the noisy pixel does not
  // unproject.
  auto observe = [&](const Camera& camera, const Eigen::Vector2d& pixel, uint64_t id, int frame, int cam,
                     uint64_t tag) -> std::optional<std::pair<Eigen::Vector2d, Eigen::Vector3d>> {
    Eigen::Vector2d noisy = pixel;
    if (options.pixel_noise_px > 0.0) {
      noisy += options.pixel_noise_px *
               GaussianPairFromHash(HashWords(
                   {options.seed, tag, id, static_cast<uint64_t>(frame), static_cast<uint64_t>(cam)}));
    }
    const auto it = out.features.find(id);
    if (tag == 1 && it != out.features.end() && it->second.outlier) {
      const double angle =
          2.0 * kSynthPi * UnitFromHash(HashWords({options.seed, 3, id, static_cast<uint64_t>(frame)}));
      noisy += options.outlier_px * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
    const std::optional<Eigen::Vector3d> bearing = camera.Unproject(noisy);
    if (!bearing) return std::nullopt;
    return std::make_pair(noisy, *bearing);
  };

  for (size_t t = 0; t < world_from_rig.size(); ++t) {
    const int frame = static_cast<int>(t);
    const Rigid3d rig_from_world = world_from_rig[t].Inverse();
    RigFrameObservations obs;
    obs.frame_index = options.first_frame_index + frame;
    obs.t_ns = options.t0_ns + static_cast<int64_t>(t) * options.frame_period_ns;
    obs.cameras.resize(static_cast<size_t>(num_cameras));
    obs.camera_missing.assign(static_cast<size_t>(num_cameras), false);
    // Visible landmarks per camera, with their noise-free pixels.
    std::vector<std::map<int, Eigen::Vector2d>> visible(static_cast<size_t>(num_cameras));
    const Eigen::Vector3d rig_position = world_from_rig[t].translation;
    for (int c = 0; c < num_cameras; ++c) {
      const Camera& camera = rig.cameras[static_cast<size_t>(c)];
      const Rigid3d cam_from_world = camera.cam_from_rig * rig_from_world;
      for (size_t j = 0; j < landmarks.size(); ++j) {
        if ((landmarks[j] - rig_position).squaredNorm() >
            (options.max_range_m + 5.0) * (options.max_range_m + 5.0)) {
          continue;
        }
        if (auto pixel = VisiblePixel(camera, cam_from_world, landmarks[j], options)) {
          visible[static_cast<size_t>(c)].emplace(static_cast<int>(j), *pixel);
        }
      }
    }
    for (int c = 0; c < num_cameras; ++c) {
      auto& tracks = active[static_cast<size_t>(c)];
      const auto& vis = visible[static_cast<size_t>(c)];
      // Tracks end when their landmark leaves the view.
      for (auto it = tracks.begin(); it != tracks.end();) {
        it = vis.count(it->first) != 0 ? std::next(it) : tracks.erase(it);
      }
      // New tracks: visible landmarks in a seeded random order.
      if (static_cast<int>(tracks.size()) < options.max_features_per_camera) {
        std::vector<std::pair<uint64_t, int>> candidates;
        for (const auto& [j, pixel] : vis) {
          if (tracks.count(j) == 0) {
            candidates.emplace_back(HashWords({options.seed, 2, static_cast<uint64_t>(frame),
                                               static_cast<uint64_t>(c), static_cast<uint64_t>(j)}),
                                    j);
          }
        }
        std::sort(candidates.begin(), candidates.end());
        for (const auto& candidate : candidates) {
          if (static_cast<int>(tracks.size()) >= options.max_features_per_camera) break;
          const uint64_t id = next_id++;
          tracks.emplace(candidate.second, id);
          FeatureTruth truth;
          truth.camera = c;
          truth.landmark = candidate.second;
          truth.outlier = options.outlier_fraction > 0.0 &&
                          UnitFromHash(HashWords({options.seed, 4, id})) < options.outlier_fraction;
          out.features.emplace(id, truth);
        }
      }
      // Observations in id order.
      std::vector<std::pair<uint64_t, int>> by_id;
      for (const auto& [j, id] : tracks) by_id.emplace_back(id, j);
      std::sort(by_id.begin(), by_id.end());
      const Camera& camera = rig.cameras[static_cast<size_t>(c)];
      for (const auto& [id, j] : by_id) {
        const auto o = observe(camera, vis.at(j), id, frame, c, 1);
        if (!o) continue;
        FeatureObservation f;
        f.id = id;
        f.pixel = o->first;
        f.bearing = o->second;
        obs.cameras[static_cast<size_t>(c)].push_back(f);
      }
    }
    if (options.cross_camera) {
      for (int a = 0; a < num_cameras; ++a) {
        for (const FeatureObservation& f : obs.cameras[static_cast<size_t>(a)]) {
          const int j = out.features.at(f.id).landmark;
          for (int b = 0; b < num_cameras; ++b) {
            if (b == a) continue;
            const auto& vis_b = visible[static_cast<size_t>(b)];
            const auto it = vis_b.find(j);
            if (it == vis_b.end()) continue;
            const auto o = observe(rig.cameras[static_cast<size_t>(b)], it->second, f.id, frame, b, 5);
            if (!o) continue;
            CrossCameraObservation x;
            x.camera_a = a;
            x.id = f.id;
            x.camera_b = b;
            x.pixel_b = o->first;
            x.bearing_b = o->second;
            obs.cross_camera.push_back(x);
          }
        }
      }
      out.num_cross_camera += static_cast<int>(obs.cross_camera.size());
    }
    out.frames.push_back(std::move(obs));
  }
  return out;
}

// The observations of one camera in frames [begin, end), as the SfM takes
// them (window frame = frame - begin).
inline std::vector<WindowObservation> CameraWindowObservations(const SyntheticRigTracks& tracks, int camera,
                                                               int begin, int end) {
  std::vector<WindowObservation> out;
  for (int t = begin; t < end; ++t) {
    for (const FeatureObservation& f :
         tracks.frames[static_cast<size_t>(t)].cameras[static_cast<size_t>(camera)]) {
      WindowObservation w;
      w.frame = t - begin;
      w.id = f.id;
      w.bearing = f.bearing;
      out.push_back(w);
    }
  }
  return out;
}

// Ground truth rig pose at frame t in the rig frame at frame `anchor` (the
// initializer's world).
inline Rigid3d AnchorFromRig(const SyntheticRigTracks& tracks, int anchor, int t) {
  return tracks.world_from_rig[static_cast<size_t>(anchor)].Inverse() *
         tracks.world_from_rig[static_cast<size_t>(t)];
}

// Ground truth camera pose at frame t in the camera frame at frame `anchor`.
inline Rigid3d CamAnchorFromCam(const SyntheticRigTracks& tracks, const Camera& camera, int anchor, int t) {
  return camera.cam_from_rig * AnchorFromRig(tracks, anchor, t) * camera.cam_from_rig.Inverse();
}

// Tracks of landmarks around the path with the same seed for both, Gaussian
// pixel noise, with or without cross-camera observations.
inline SyntheticRigTracks NoisyRigTracks(const Rig& rig, const std::vector<Rigid3d>& world_from_rig,
                                         double noise_px, uint64_t seed, bool cross_camera) {
  LandmarkOptions landmark_options;
  landmark_options.seed = seed;
  TrackOptions options;
  options.seed = seed;
  options.pixel_noise_px = noise_px;
  options.cross_camera = cross_camera;
  return MakeRigTracks(rig, world_from_rig, LandmarksAroundPath(world_from_rig, landmark_options), options);
}

}  // namespace mcvo::testing
