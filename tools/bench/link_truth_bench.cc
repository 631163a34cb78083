// Precision of a run's cross-camera links across time
// (loop/cross_camera_links.h) against the renderer's ground truth.
//
//   mcvo_bench_link_truth DATASET RUN_DIR [--per-link]
//
// DATASET is a `mcvo synth` output (meta.json names the scene and seed,
// rig.json the cameras, groundtruth.tum the rig poses); RUN_DIR the output
// of `mcvo run` on it (cross_camera_links.csv). Each link's source pixel
// (L's observation) is cast into the scene (static geometry only) from the
// true pose, and the point it hits projected into the linked camera at the
// linked frame: the link is correct when that projection is within
// kCorrectPx of M's pixel (tracked features are within a pixel of the
// truth after many frames: results/anchor_tracking.md). Printed: links, the
// cast ones and the correct fraction, overall and by Hamming distance and
// by view angle, and the median pixel error of the wrong ones; with
// --per-link first a line per link: "link FRAME SOURCE_FRAME BITS ERROR_PX".
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mcvo/io/rig_io.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/synth/scene.h"
#include "mcvo/util/error.h"

namespace {

constexpr double kCorrectPx = 3.0;

struct Row {
  int frame = 0, camera = 0, source_frame = 0, source_camera = 0, distance = 0;
  Eigen::Vector2d pixel, source_pixel;
  double view_angle_deg = 0.0;
};

std::vector<Row> ReadLinks(const std::string& path) {
  std::ifstream in(path);
  if (!in) MCVO_THROW_INPUT(path, ": cannot open");
  std::string line;
  std::getline(in, line);  // header
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream s(line);
    Row r;
    int keyframe = 0, source_keyframe = 0;
    long long landmark = 0, source_landmark = 0;
    s >> keyframe >> r.frame >> r.camera >> r.pixel.x() >> r.pixel.y() >> landmark >> source_keyframe >>
        r.source_frame >> r.source_camera >> r.source_pixel.x() >> r.source_pixel.y() >> source_landmark >>
        r.distance >> r.view_angle_deg;
    if (!s) MCVO_THROW_INPUT(path, ": bad line: ", line);
    rows.push_back(r);
  }
  return rows;
}

struct Tally {
  int cast = 0, correct = 0;
  void Add(bool ok) {
    ++cast;
    correct += ok ? 1 : 0;
  }
  std::string Text() const {
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%6d  %5.1f %%", cast, cast > 0 ? 100.0 * correct / cast : 0.0);
    return buffer;
  }
};

int Run(const std::string& dataset, const std::string& run_dir, bool per_link) {
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
  const std::vector<Row> rows = ReadLinks(run_dir + "/cross_camera_links.csv");
  const int64_t first_t_ns = gt.poses.front().t_ns;

  // The static scene point a pixel sees, if any.
  const auto cast = [&](int frame, int camera,
                        const Eigen::Vector2d& pixel) -> std::optional<Eigen::Vector3d> {
    if (frame < 0 || static_cast<size_t>(frame) >= gt.poses.size()) return std::nullopt;
    if (camera < 0 || camera >= rig.NumCameras()) return std::nullopt;
    const mcvo::Camera& cam = rig.cameras[static_cast<size_t>(camera)];
    const std::optional<Eigen::Vector3d> bearing = cam.Unproject(pixel);
    if (!bearing) return std::nullopt;
    const mcvo::StampedPose& pose = gt.poses[static_cast<size_t>(frame)];
    const mcvo::Rigid3d world_from_cam = pose.world_from_body * cam.cam_from_rig.Inverse();
    const auto hit = world.scene.Intersect(world_from_cam.translation, world_from_cam.rotation * *bearing,
                                           pose.t_ns - first_t_ns);
    if (!hit || hit->moving_object >= 0) return std::nullopt;
    return hit->point;
  };

  Tally all;
  std::vector<std::pair<int, Tally>> by_distance = {{20, {}}, {30, {}}, {40, {}},
                                                    {50, {}}, {64, {}}, {256, {}}};
  std::vector<std::pair<double, Tally>> by_angle = {{10, {}}, {20, {}}, {30, {}}, {40, {}}, {180, {}}};
  std::vector<double> wrong_error;
  for (const Row& r : rows) {
    const auto hit = cast(r.source_frame, r.source_camera, r.source_pixel);
    if (!hit || r.frame < 0 || static_cast<size_t>(r.frame) >= gt.poses.size()) continue;
    if (r.camera < 0 || r.camera >= rig.NumCameras()) continue;
    const mcvo::Camera& camera = rig.cameras[static_cast<size_t>(r.camera)];
    const mcvo::Rigid3d cam_from_world =
        camera.cam_from_rig * gt.poses[static_cast<size_t>(r.frame)].world_from_body.Inverse();
    const std::optional<Eigen::Vector2d> pixel = camera.Project(cam_from_world * *hit);
    const double error = pixel ? (*pixel - r.pixel).norm() : std::numeric_limits<double>::infinity();
    const bool ok = error <= kCorrectPx;
    if (!ok) wrong_error.push_back(error);
    all.Add(ok);
    if (per_link) std::printf("link %d %d %d %.2f\n", r.frame, r.source_frame, r.distance, error);
    for (auto& [bound, tally] : by_distance) {
      if (r.distance <= bound) {
        tally.Add(ok);
        break;
      }
    }
    for (auto& [bound, tally] : by_angle) {
      if (r.view_angle_deg <= bound) {
        tally.Add(ok);
        break;
      }
    }
  }
  std::sort(wrong_error.begin(), wrong_error.end());
  std::printf("links %zu, cast %d, correct %s\n", rows.size(), all.cast, all.Text().c_str());
  std::printf("by Hamming distance (bits, at most):\n");
  for (const auto& [bound, tally] : by_distance) std::printf("  %4d  %s\n", bound, tally.Text().c_str());
  std::printf("by view angle (deg, at most):\n");
  for (const auto& [bound, tally] : by_angle) std::printf("  %4.0f  %s\n", bound, tally.Text().c_str());
  if (!wrong_error.empty()) {
    std::printf("wrong links: median error %.1f px\n", wrong_error[wrong_error.size() / 2]);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3 && !(argc == 4 && std::string(argv[3]) == "--per-link")) {
    std::fprintf(stderr, "usage: mcvo_bench_link_truth DATASET RUN_DIR [--per-link]\n");
    return 2;
  }
  try {
    return Run(argv[1], argv[2], argc == 4);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mcvo_bench_link_truth: %s\n", e.what());
    return 1;
  }
}
