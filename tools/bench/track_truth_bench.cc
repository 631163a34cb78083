// Accuracy of a track file against the renderer's ground truth
// (tools/bench_anchor.sh, results/anchor_tracking.md).
//
//   mcvo_bench_track_truth DATASET TRACKS [TRUE_TRACKS [MODE]]
//
// DATASET is a `mcvo synth` output (meta.json names the scene and seed,
// rig.json the cameras, groundtruth.tum the rig poses); TRACKS a track file
// of `mcvo track` on it. Each feature's first observation is cast into the
// scene (static geometry only; features on moving objects are skipped); at
// every later observation the error is the distance between the tracked
// pixel and the projection of that 3-D point. Printed per camera and track
// length: observations, median, 75th and 90th percentile of the error, and
// the median of its component along the feature's motion since it was
// detected (a systematic overshoot or lag shows there).
//
// Cross-camera matches (version 2 and later): per camera pair, the error of
// the matched pixel against the projection into camera b of the point camera
// a's feature was detected on, and the signed error of the depth the match
// triangulates relative to that point's depth (a bias there is a bias of the
// metric scale the matches give).
//
// A second table splits the matches by the true depth and gives the
// relative error of the inverse depth (true / matched - 1, linear in the
// pixel error along the epipolar curve): median and trimmed mean (5-95 %).
// A bias there is a bias of the metric scale, even where it is a few
// hundredths of a pixel and the median pixel error does not show it.
//
// TRUE_TRACKS (optional): the same track file with every observation after
// the first, and every cross-camera match, replaced by that projection (features on moving objects or
// leaving the camera's model keep their tracked pixels): `mcvo run --tracks`
// on it shows what the back end makes of the same features without
// tracking error. With MODE = matches (default: all), the tracks stay as
// tracked and only the cross-camera matches move, each to the projection
// into b of the point a's ray hits at the pixel a tracked: perfect matching
// of the features as tracked, so that the cost of the matching errors
// alone can be told from that of the tracks. The printed statistics are
// always those of TRACKS.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mcvo/frontend/track_file.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/synth/scene.h"
#include "mcvo/util/error.h"

namespace {

using mcvo::Camera;
using mcvo::Rigid3d;

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * static_cast<double>(values.size() - 1))];
}

struct FirstSight {
  bool on_static_scene = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector2f pixel = Eigen::Vector2f::Zero();
};

int Run(const std::string& dataset, const std::string& tracks, const std::string& true_tracks,
        bool matches_only) {
  std::ifstream meta_file(dataset + "/meta.json");
  if (!meta_file) MCVO_THROW_INPUT(dataset, "/meta.json: cannot open (not a `mcvo synth` dataset)");
  const nlohmann::json meta = nlohmann::json::parse(meta_file, nullptr, false);
  if (meta.is_discarded() || !meta.contains("scene") || !meta.contains("seed")) {
    MCVO_THROW_INPUT(dataset, "/meta.json: expected the keys scene and seed");
  }
  const mcvo::Rig rig = mcvo::ReadRig(dataset + "/rig.json");
  const mcvo::Trajectory gt =
      mcvo::ReadTrajectory(dataset + "/groundtruth.tum", mcvo::TrajectoryFormat::kTum);
  if (gt.poses.empty()) MCVO_THROW_INPUT(dataset, "/groundtruth.tum: no poses");
  const mcvo::synth::SceneWithRoute world =
      mcvo::synth::BuildScene(meta["scene"].get<std::string>(), meta["seed"].get<uint64_t>());
  mcvo::TrackFileReader reader(tracks);
  const mcvo::TrackFileHeader& header = reader.header();
  std::vector<const Camera*> cameras;
  for (const std::string& name : header.camera_names) {
    const Camera* found = nullptr;
    for (const Camera& camera : rig.cameras)
      if (camera.name == name) found = &camera;
    if (found == nullptr) MCVO_THROW_INPUT(tracks, ": camera ", name, " is not in ", dataset, "/rig.json");
    cameras.push_back(found);
  }
  const int64_t first_t_ns = gt.poses.front().t_ns;
  // Track lengths reported: 2, 3, 5, 9, 17, 33 (one step, then doubling).
  const std::vector<int> lengths = {2, 3, 5, 9, 17, 33};
  std::map<std::pair<size_t, uint64_t>, FirstSight> first_sight;
  std::map<std::pair<size_t, int>, std::vector<double>> errors, along;
  struct CrossStats {
    std::vector<double> errors, relative_depth;
    // Relative error of the inverse depth (true depth / matched depth - 1),
    // linear in the matched pixel's error along the epipolar curve, by the
    // true depth's bin (kDepthBinsM).
    std::map<int, std::vector<double>> inverse_depth;
  };
  const std::vector<double> kDepthBinsM = {5.0, 10.0, 20.0,
                                           40.0};         // bin i: below kDepthBinsM[i]; last: beyond
  std::map<std::pair<size_t, size_t>, CrossStats> cross;  // (camera a, camera b)
  std::optional<mcvo::TrackFileWriter> writer;
  if (!true_tracks.empty()) writer.emplace(true_tracks, header);
  while (std::optional<mcvo::MultiCameraFrame> frame = reader.Next()) {
    const size_t index = static_cast<size_t>(frame->frame_index);
    if (index >= gt.poses.size()) MCVO_THROW_INPUT(tracks, ": frame ", index, " has no ground-truth pose");
    std::map<std::pair<size_t, uint64_t>, Eigen::Vector2f>
        a_pixels;  // as tracked (TRUE_TRACKS replaces them)
    for (size_t c = 0; c < frame->cameras.size(); ++c) {
      for (const mcvo::TrackedFeature& f : frame->cameras[c].features) a_pixels[{c, f.id}] = f.pixel;
    }
    for (size_t c = 0; c < frame->cameras.size(); ++c) {
      const Camera& camera = *cameras[c];
      const Rigid3d world_from_cam = gt.poses[index].world_from_body * camera.cam_from_rig.Inverse();
      const Rigid3d cam_from_world = world_from_cam.Inverse();
      for (mcvo::TrackedFeature& f : frame->cameras[c].features) {
        const auto key = std::make_pair(c, f.id);
        auto it = first_sight.find(key);
        if (it == first_sight.end()) {
          FirstSight sight;
          sight.pixel = f.pixel;
          if (const auto bearing = camera.Unproject(f.pixel.cast<double>())) {
            const auto hit = world.scene.Intersect(
                world_from_cam.translation, world_from_cam.rotation * *bearing, frame->t_ns - first_t_ns);
            if (hit && hit->moving_object < 0) {
              sight.on_static_scene = true;
              sight.point = hit->point;
            }
          }
          first_sight.emplace(key, sight);
          continue;
        }
        if (!it->second.on_static_scene) continue;
        const auto projection = camera.Project(cam_from_world * it->second.point);
        if (!projection) continue;
        const Eigen::Vector2f truth = projection->cast<float>();
        const Eigen::Vector2f error = f.pixel - truth;
        if (!matches_only) f.pixel = truth;  // for TRUE_TRACKS
        const auto slot = std::find(lengths.begin(), lengths.end(), f.track_length);
        if (slot == lengths.end()) continue;
        const Eigen::Vector2f motion = truth - it->second.pixel;
        const int l = static_cast<int>(slot - lengths.begin());
        errors[{c, l}].push_back(error.norm());
        if (motion.norm() > 1.0f) along[{c, l}].push_back(error.dot(motion.normalized()));
      }
    }
    // Cross-camera matches against the projection into camera b of the
    // point camera a's feature was detected on; the signed error of the
    // depth the match triangulates (a's ray at its current pixel, b's at the
    // matched pixel, midpoint) relative to that point's depth along a's ray
    // is the scale the match would lend the back end.
    for (mcvo::CrossCameraMatch& m : frame->cross_matches) {
      const size_t a = static_cast<size_t>(m.camera_a), b = static_cast<size_t>(m.camera_b);
      if (a >= cameras.size() || b >= cameras.size()) continue;
      const auto it = first_sight.find({a, m.id_a});
      if (it == first_sight.end() || !it->second.on_static_scene) continue;
      const Rigid3d world_from_rig = gt.poses[index].world_from_body;
      const Rigid3d b_from_world = (world_from_rig * cameras[b]->cam_from_rig.Inverse()).Inverse();
      const Rigid3d world_from_a = world_from_rig * cameras[a]->cam_from_rig.Inverse();
      // TRUE_TRACKS: the projection of the point a's feature was detected
      // on (a's pixel was replaced by its projection above). The errors: the
      // point a's ray hits at the pixel a tracked (bearing_a in the frame
      // where its pixel was read), so a's own tracking error stays out.
      const auto truth = cameras[b]->Project(b_from_world * it->second.point);
      if (!truth) continue;
      const Eigen::Vector2f matched = m.pixel_b;  // as matched (the statistics are of TRACKS)
      if (writer && !matches_only) m.pixel_b = truth->cast<float>();
      const auto bearing_a = cameras[a]->Unproject(a_pixels[{a, m.id_a}].cast<double>());
      if (!bearing_a) continue;
      const auto hit = world.scene.Intersect(world_from_a.translation, world_from_a.rotation * *bearing_a,
                                             frame->t_ns - first_t_ns);
      if (!hit || hit->moving_object >= 0) continue;
      const auto seen = cameras[b]->Project(b_from_world * hit->point);
      if (!seen) continue;
      if (writer && matches_only) m.pixel_b = seen->cast<float>();
      CrossStats& stats = cross[{a, b}];
      stats.errors.push_back((matched - seen->cast<float>()).norm());
      const auto bearing_b = cameras[b]->Unproject(matched.cast<double>());
      if (bearing_b) {
        // In a's frame: a's centre at 0, b's at t; rays r_a, r_b.
        const Rigid3d a_from_b = cameras[a]->cam_from_rig * cameras[b]->cam_from_rig.Inverse();
        const Eigen::Vector3d ra = bearing_a->normalized(), rb = a_from_b.rotation * bearing_b->normalized();
        const Eigen::Vector3d t = a_from_b.translation;
        const double k = ra.dot(rb);
        const double denominator = 1.0 - k * k;
        if (denominator > 1e-12) {
          const double da = (ra.dot(t) - k * rb.dot(t)) / denominator;
          const double true_depth = (hit->point - world_from_a.translation).norm();
          if (da > 0.0 && true_depth > 0.0) {
            stats.relative_depth.push_back(da / true_depth - 1.0);
            const int bin = static_cast<int>(
                std::upper_bound(kDepthBinsM.begin(), kDepthBinsM.end(), true_depth) - kDepthBinsM.begin());
            stats.inverse_depth[bin].push_back(true_depth / da - 1.0);
          }
        }
      }
    }
    if (writer) writer->Write(*frame);
  }
  if (writer) writer->Commit();
  std::printf(
      "| camera | track length | observations | median px | p75 px | p90 px | along motion, median px |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (size_t c = 0; c < cameras.size(); ++c) {
    for (size_t l = 0; l < lengths.size(); ++l) {
      const std::vector<double>& e = errors[{c, static_cast<int>(l)}];
      if (e.empty()) continue;
      std::printf("| %s | %d | %zu | %.3f | %.3f | %.3f | %+.3f |\n", cameras[c]->name.c_str(), lengths[l],
                  e.size(), Quantile(e, 0.5), Quantile(e, 0.75), Quantile(e, 0.9),
                  Quantile(along[{c, static_cast<int>(l)}], 0.5));
    }
  }
  if (!cross.empty()) {
    std::printf(
        "\n| cross-camera pair | matches | median px | p90 px | depth error, median %% | p10 %% | p90 %% "
        "|\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    for (const auto& [pair, stats] : cross) {
      std::printf("| %s - %s | %zu | %.3f | %.3f | %+.3f | %+.3f | %+.3f |\n",
                  cameras[pair.first]->name.c_str(), cameras[pair.second]->name.c_str(), stats.errors.size(),
                  Quantile(stats.errors, 0.5), Quantile(stats.errors, 0.9),
                  100.0 * Quantile(stats.relative_depth, 0.5), 100.0 * Quantile(stats.relative_depth, 0.1),
                  100.0 * Quantile(stats.relative_depth, 0.9));
    }
    // A bias of the inverse depth (its mean over the matches within the
    // 5-95 % quantiles, so a few gross errors do not hide it) is a bias of
    // the scale the matches lend; its median shows whether it is the bulk.
    std::printf(
        "\n| cross-camera pair | true depth m | matches | inverse-depth error, median %% | trimmed mean %% "
        "|\n");
    std::printf("|---|---|---|---|---|\n");
    for (const auto& [pair, stats] : cross) {
      for (const auto& [bin, values] : stats.inverse_depth) {
        const std::string range =
            bin == 0 ? "< " + std::to_string(static_cast<int>(kDepthBinsM[0]))
            : bin == static_cast<int>(kDepthBinsM.size())
                ? ">= " + std::to_string(static_cast<int>(kDepthBinsM.back()))
                : std::to_string(static_cast<int>(kDepthBinsM[static_cast<size_t>(bin - 1)])) + "-" +
                      std::to_string(static_cast<int>(kDepthBinsM[static_cast<size_t>(bin)]));
        const double lo = Quantile(values, 0.05), hi = Quantile(values, 0.95);
        double sum = 0.0;
        int n = 0;
        for (const double v : values) {
          if (v < lo || v > hi) continue;
          sum += v;
          ++n;
        }
        std::printf("| %s - %s | %s | %zu | %+.3f | %+.3f |\n", cameras[pair.first]->name.c_str(),
                    cameras[pair.second]->name.c_str(), range.c_str(), values.size(),
                    100.0 * Quantile(values, 0.5), n > 0 ? 100.0 * sum / n : 0.0);
      }
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc == 5 ? argv[4] : "all";
  if (argc < 3 || argc > 5 || (mode != "all" && mode != "matches")) {
    std::fprintf(
        stderr,
        "usage: mcvo_bench_track_truth DATASET TRACKS [TRUE_TRACKS [all|matches]] (a `mcvo synth` "
        "dataset, a `mcvo track` file of it, the track file to write with true pixels: every observation "
        "and match, or only the matches, each where b sees the point a's tracked pixel sees)\n");
    return 2;
  }
  try {
    return Run(argv[1], argv[2], argc >= 4 ? argv[3] : "", mode == "matches");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mcvo_bench_track_truth: error: %s\n", e.what());
    return 1;
  }
}
