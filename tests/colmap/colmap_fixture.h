// Fixtures of the COLMAP export tests: a three-camera rig (pinhole looking
// forward, Kannala-Brandt fisheye looking left, the KITTI-360 MEI fisheye
// looking right), keyframes with known poses, landmarks projected exactly
// into them, a closed textured room that the synth renderer turns into
// images consistent with all of it, and helpers for folders and commands.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "camera/test_cameras.h"
#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/map/sparse_map.h"
#include "mcvo/synth/renderer.h"
#include "mcvo/synth/scene.h"

namespace mcvo::test {

namespace fs = std::filesystem;

// A folder for one test process (ctest runs each TEST as its own process),
// removed at the end.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name)
      : path_(fs::path(::testing::TempDir()) / ("mcvo_colmap_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// cam_from_rig for a camera whose optical axis is `forward_in_rig` and whose
// image x axis is `right_in_rig` (rig: x forward, y left, z up), turned a
// little about a tilted axis, at `position_in_rig`.
inline Rigid3d CamFromRig(const Eigen::Vector3d& forward_in_rig, const Eigen::Vector3d& right_in_rig,
                          const Eigen::Vector3d& position_in_rig, double tilt_rad) {
  Eigen::Matrix3d cam_from_rig_rotation;
  cam_from_rig_rotation.row(0) = right_in_rig.transpose();
  cam_from_rig_rotation.row(1) = forward_in_rig.cross(right_in_rig).transpose();  // image y: down
  cam_from_rig_rotation.row(2) = forward_in_rig.transpose();
  const Eigen::Matrix3d tilt =
      Eigen::AngleAxisd(tilt_rad, Eigen::Vector3d(0.3, 1.0, -0.2).normalized()).matrix();
  const Eigen::Matrix3d rotation = tilt * cam_from_rig_rotation;
  return Rigid3d(rotation, -(rotation * position_in_rig));
}

// Pinhole forward, KB fisheye left, MEI fisheye right. `scale` shrinks the
// pinhole and KB images (1: 640x480, 512x512), `mei_scale` the MEI's (1: 1400x1400).
inline Rig ThreeCameraRig(double scale = 1.0, double mei_scale = 1.0) {
  Camera pinhole =
      MakeCamera("cam0_pinhole", CameraModelId::kPinhole, {500.0, 490.0, 320.0, 240.0}, 640, 480);
  Camera kb = MakeCamera(
      "cam1_kb", CameraModelId::kKannalaBrandt,
      {190.97847715128717, 190.9733070521226, 254.93170605935475, 256.8974428996504, 0.0034823894022493434,
       0.0007150348452162257, -0.0020532361418706202, 0.00020293673591811182},
      512, 512);
  Camera mei = Kitti360Image02();
  mei.name = "cam2_mei";
  pinhole.cam_from_rig = CamFromRig({1, 0, 0}, {0, -1, 0}, {0.4, 0.1, 0.2}, 0.05);
  kb.cam_from_rig = CamFromRig({0, 1, 0}, {1, 0, 0}, {0.1, 0.3, 0.1}, -0.08);
  mei.cam_from_rig = CamFromRig({0, -1, 0}, {-1, 0, 0}, {0.0, -0.3, 0.15}, 0.1);
  Rig rig;
  rig.cameras.push_back(scale == 1.0 ? pinhole : ScaledCamera(pinhole, scale));
  rig.cameras.push_back(scale == 1.0 ? kb : ScaledCamera(kb, scale));
  rig.cameras.push_back(mei_scale == 1.0 ? mei : ScaledCamera(mei, mei_scale));
  return rig;
}

// Keyframe poses: the rig moves along x (about 0.4 m apart), turning and
// bobbing a little.
inline std::vector<Rigid3d> KeyframePoses(int count) {
  std::vector<Rigid3d> poses;
  for (int k = 0; k < count; ++k) {
    const Eigen::Matrix3d rotation = (Eigen::AngleAxisd(0.06 * k - 0.1, Eigen::Vector3d::UnitZ()) *
                                      Eigen::AngleAxisd(0.02 * std::sin(1.3 * k), Eigen::Vector3d::UnitX()))
                                         .matrix();
    poses.emplace_back(rotation, Eigen::Vector3d(0.4 * k, 0.05 * std::sin(0.9 * k), 0.03 * k));
  }
  return poses;
}

inline std::string FrameName(int frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.png", frame);
  return name;
}

// A map whose keyframes see `points` exactly: every landmark projected into
// every camera of every keyframe where it is in front, inside the model's
// domain and inside the image (with a 2 px margin). Landmark ids 10, 13, 16,
// ... (not contiguous, not from 0). Image paths images/<camera>/<frame>.png,
// relative. Frame indices 5, 7, 9, ...
inline SparseMap ProjectedMap(const Rig& rig, const std::vector<Rigid3d>& world_from_rig,
                              const std::vector<Eigen::Vector3d>& points) {
  SparseMap map;
  for (size_t i = 0; i < points.size(); ++i)
    map.landmarks.push_back({static_cast<int64_t>(10 + 3 * i), points[i]});
  for (size_t k = 0; k < world_from_rig.size(); ++k) {
    MapKeyframe keyframe;
    keyframe.frame_index = static_cast<int>(5 + 2 * k);
    keyframe.t_ns = 1000000000LL + 100000000LL * static_cast<int64_t>(k);
    keyframe.world_from_rig = world_from_rig[k];
    for (int c = 0; c < rig.NumCameras(); ++c) {
      const Camera& camera = rig.cameras[c];
      keyframe.images.push_back(fs::path("images") / camera.name / FrameName(keyframe.frame_index));
      const Rigid3d cam_from_world = camera.cam_from_rig * world_from_rig[k].Inverse();
      for (const MapLandmark& landmark : map.landmarks) {
        const std::optional<Eigen::Vector2d> pixel = camera.Project(cam_from_world * landmark.position_world);
        if (!pixel || pixel->x() < 2.0 || pixel->y() < 2.0 || pixel->x() > camera.width - 3.0 ||
            pixel->y() > camera.height - 3.0)
          continue;
        keyframe.observations.push_back({c, landmark.id, *pixel});
      }
    }
    map.keyframes.push_back(std::move(keyframe));
  }
  return map;
}

// Random points around the keyframes, 2 to 12 m away.
inline std::vector<Eigen::Vector3d> RandomPoints(int count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> distance(2.0, 12.0);
  std::vector<Eigen::Vector3d> points;
  while (static_cast<int>(points.size()) < count) {
    Eigen::Vector3d direction(unit(rng), unit(rng), 0.6 * unit(rng));
    if (direction.norm() < 0.2) continue;
    points.push_back(Eigen::Vector3d(1.0, 0.0, 0.0) + distance(rng) * direction.normalized());
  }
  return points;
}

// The closed room of the rendered tests: a box of textured posters, 18 x 14 x
// 6 m, around the keyframes.
struct Room {
  Eigen::Vector3d min_corner{-7.0, -7.0, -2.5};
  Eigen::Vector3d max_corner{11.0, 7.0, 3.5};

  synth::Scene MakeScene() const {
    synth::Scene scene;
    synth::BoxSpec box;
    box.center = Eigen::Vector3d(0.5 * (min_corner.x() + max_corner.x()),
                                 0.5 * (min_corner.y() + max_corner.y()), min_corner.z());
    box.size = max_corner - min_corner;
    box.side_material = synth::Material::kPoster;
    box.top_material = synth::Material::kPoster;
    box.with_bottom = true;
    box.texture_seed = 7;
    scene.AddBox(box);
    scene.Build();
    return scene;
  }
  // Distance of a point from the nearest wall.
  double DistanceToWalls(const Eigen::Vector3d& point) const {
    double distance = 1e9;
    for (int i = 0; i < 3; ++i) {
      distance = std::min(distance, std::abs(point[i] - min_corner[i]));
      distance = std::min(distance, std::abs(point[i] - max_corner[i]));
    }
    return distance;
  }
};

// Points on the room's walls seen by the first keyframe: the hits of a grid
// of rays through each camera's image.
inline std::vector<Eigen::Vector3d> WallPoints(const Rig& rig, const Rigid3d& world_from_rig,
                                               const synth::Scene& scene, int grid) {
  std::vector<Eigen::Vector3d> points;
  for (const Camera& camera : rig.cameras) {
    const Rigid3d world_from_cam = world_from_rig * camera.cam_from_rig.Inverse();
    for (int j = 0; j < grid; ++j) {
      for (int i = 0; i < grid; ++i) {
        const Eigen::Vector2d pixel((i + 0.5) * camera.width / grid, (j + 0.5) * camera.height / grid);
        const std::optional<Eigen::Vector3d> bearing = camera.Unproject(pixel);
        if (!bearing) continue;
        const std::optional<synth::Hit> hit =
            scene.Intersect(world_from_cam.translation, world_from_cam.rotation * *bearing, 0);
        if (hit) points.push_back(hit->point);
      }
    }
  }
  return points;
}

// Renders every keyframe image of `map` into dataset_root/<image path> (8-bit grey PNG).
inline void RenderImages(const Rig& rig, const SparseMap& map, const synth::Scene& scene,
                         const fs::path& dataset_root) {
  synth::RenderOptions options;
  options.samples_per_axis = 2;
  options.threads = 2;
  for (const MapKeyframe& keyframe : map.keyframes) {
    for (int c = 0; c < rig.NumCameras(); ++c) {
      const cv::Mat image = synth::RenderImageAtPoses(scene, rig, c, {keyframe.world_from_rig}, {0},
                                                      keyframe.frame_index, options);
      const fs::path path = dataset_root / keyframe.images[c];
      fs::create_directories(path.parent_path());
      ASSERT_TRUE(cv::imwrite(path.string(), image)) << path;
    }
  }
}

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

inline std::string ShellQuote(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

inline CommandResult RunCommand(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer{};
  size_t n = 0;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

inline std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Writes a keyframe image for every listed path: `make(camera)` gives it.
template <typename Make>
inline void WriteImages(const Rig& rig, const SparseMap& map, const fs::path& root, Make&& make) {
  for (const MapKeyframe& keyframe : map.keyframes) {
    for (int c = 0; c < rig.NumCameras(); ++c) {
      const fs::path path = root / keyframe.images[c];
      fs::create_directories(path.parent_path());
      ASSERT_TRUE(cv::imwrite(path.string(), make(rig.cameras[c])));
    }
  }
}

inline cv::Mat NoiseImage(const Camera& camera) {
  cv::Mat image(camera.height, camera.width, CV_8UC1);
  cv::RNG rng(static_cast<uint64_t>(camera.width) * 7919u + static_cast<uint64_t>(camera.height));
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.5);
  return image;
}

// Relative path -> bytes of every file (links: their target) below dir.
inline std::map<std::string, std::string> TreeContents(const fs::path& dir) {
  std::map<std::string, std::string> contents;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const std::string relative = fs::relative(entry.path(), dir).generic_string();
    if (entry.is_symlink()) {
      contents[relative] = "link:" + fs::read_symlink(entry.path()).string();
    } else if (entry.is_regular_file()) {
      contents[relative] = ReadBytes(entry.path());
    }
  }
  return contents;
}

}  // namespace mcvo::test
