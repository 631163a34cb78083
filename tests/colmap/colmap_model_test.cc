// COLMAP model files, camera mapping and the export of a sparse map, checked
// against independent computations (no COLMAP binary needed; see
// colmap_program_test.cc for the checks with the real program).
#include "mcvo/colmap/colmap_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "camera/test_cameras.h"
#include "colmap/colmap_fixture.h"
#include "mcvo/camera/models.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

using test::NoiseImage;
using test::ScratchDir;
using test::TreeContents;
using test::WriteImages;
namespace fs = std::filesystem;

ColmapExportOptions NoImages() {
  ColmapExportOptions options;
  options.image_mode = ColmapImageMode::kNone;
  options.sample_colors = false;
  return options;
}

struct Synthetic {
  Rig rig;
  SparseMap map;
};

Synthetic MakeSynthetic(int points = 300, int keyframes = 6) {
  Synthetic s;
  s.rig = test::ThreeCameraRig();
  s.map = test::ProjectedMap(s.rig, test::KeyframePoses(keyframes), test::RandomPoints(points, 1));
  return s;
}

// Whether the exporter keeps an observation (the documented rule, written
// out independently): the landmark in front of the image plane, and the
// observed pixel's bearing in front and within the camera's angle.
bool Kept(const Rig& rig, const MapKeyframe& keyframe, const MapObservation& observation,
          const Eigen::Vector3d& point, double fisheye_max_angle_deg) {
  const Camera& camera = rig.cameras[observation.camera];
  const Eigen::Vector3d point_in_cam = camera.cam_from_rig * (keyframe.world_from_rig.Inverse() * point);
  if (point_in_cam.z() < DBL_EPSILON) return false;
  const std::optional<Eigen::Vector3d> bearing = camera.Unproject(observation.pixel);
  if (!bearing || bearing->z() <= 0.0) return false;
  const double angle = std::atan2(bearing->head<2>().norm(), bearing->z()) * 180.0 / M_PI;
  const bool fitted = camera.model == CameraModelId::kMei || camera.model == CameraModelId::kDoubleSphere;
  return !fitted || angle <= fisheye_max_angle_deg;
}

const MapLandmark& Landmark(const SparseMap& map, int64_t id) {
  for (const MapLandmark& landmark : map.landmarks) {
    if (landmark.id == id) return landmark;
  }
  ADD_FAILURE() << "no landmark " << id;
  return map.landmarks.front();
}

// ---------------------------------------------------------------------------
// Cameras.

TEST(ColmapCamera, ExactModelsProjectAsTheRigCameraPlusHalfAPixel) {
  std::vector<Camera> cameras = test::AllTestCameras();
  Camera radtan_no_k3 = cameras[2];
  radtan_no_k3.name = "radtan_no_k3";
  radtan_no_k3.params[8] = 0.0;
  cameras.push_back(radtan_no_k3);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int checked_cameras = 0;
  for (const Camera& camera : cameras) {
    ColmapCameraModel expected;
    switch (camera.model) {
      case CameraModelId::kPinhole:
        expected = ColmapCameraModel::kPinhole;
        break;
      case CameraModelId::kRadTan:
        expected = camera.params[8] == 0.0 ? ColmapCameraModel::kOpenCv : ColmapCameraModel::kFullOpenCv;
        break;
      case CameraModelId::kKannalaBrandt:
        expected = ColmapCameraModel::kOpenCvFisheye;
        break;
      default:
        continue;
    }
    SCOPED_TRACE(camera.name);
    const ColmapCameraExport out = ConvertCameraToColmap(camera, 4, ColmapExportOptions());
    EXPECT_EQ(out.camera.id, 4u);
    EXPECT_EQ(out.camera.model, expected);
    EXPECT_EQ(out.camera.width, static_cast<uint64_t>(camera.width));
    EXPECT_EQ(out.camera.height, static_cast<uint64_t>(camera.height));
    EXPECT_FALSE(out.fitted);
    EXPECT_FALSE(out.undistorted);
    int checked = 0;
    for (int i = 0; i < 500; ++i) {
      const double theta = unit(rng) * 88.0 * M_PI / 180.0;
      const Eigen::Vector3d point = (1.0 + 10.0 * unit(rng)) * test::Direction(theta, 2.0 * M_PI * unit(rng));
      if (!test::IsInDomain(camera, point)) continue;
      const std::optional<Eigen::Vector2d> pixel = camera.Project(point);
      const std::optional<Eigen::Vector2d> colmap = ColmapProject(out.camera, point);
      ASSERT_TRUE(pixel && colmap);
      EXPECT_LT((*colmap - (*pixel + Eigen::Vector2d(0.5, 0.5))).norm(), 1e-9 * (1.0 + pixel->norm()));
      ++checked;
    }
    EXPECT_GT(checked, 100);
    ++checked_cameras;
  }
  EXPECT_EQ(checked_cameras, 6);  // 1 pinhole, 3 radtan, 2 Kannala-Brandt
}

TEST(ColmapCamera, PrincipalPointMovesByHalfAPixel) {
  const Camera camera =
      test::MakeCamera("p", CameraModelId::kPinhole, {500.0, 490.0, 320.0, 240.0}, 640, 480);
  const ColmapCameraExport out = ConvertCameraToColmap(camera, 1, ColmapExportOptions());
  EXPECT_EQ(out.camera.params, (std::vector<double>{500.0, 490.0, 320.5, 240.5}));
  // The optical axis hits the pixel that OpenCV calls (320, 240) and COLMAP (320.5, 240.5).
  EXPECT_EQ(*ColmapProject(out.camera, Eigen::Vector3d(0.0, 0.0, 3.0)), Eigen::Vector2d(320.5, 240.5));
  EXPECT_FALSE(ColmapProject(out.camera, Eigen::Vector3d(0.0, 0.0, -3.0)).has_value());
}

TEST(ColmapCamera, FitsOpenCvFisheyeToMeiAndDoubleSphere) {
  const std::vector<Camera> cameras = {test::Kitti360Image02(), test::Kitti360Image03(),
                                       test::AllTestCameras()[7], test::AllTestCameras()[8],
                                       test::AllTestCameras()[9]};
  ColmapExportOptions options;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const Camera& camera : cameras) {
    SCOPED_TRACE(camera.name);
    const ColmapCameraExport out = ConvertCameraToColmap(camera, 2, options);
    EXPECT_TRUE(out.fitted);
    EXPECT_EQ(out.camera.model, ColmapCameraModel::kOpenCvFisheye);
    EXPECT_EQ(out.max_angle_deg, options.fisheye_max_angle_deg);
    EXPECT_GT(out.fit_samples, 1000);
    std::printf("fit %-12s %4dx%-4d samples %4d  RMS %.4f px  max %.4f px\n", camera.name.c_str(),
                camera.width, camera.height, out.fit_samples, out.fit_rms_px, out.fit_max_px);
    // KITTI-360 image_03 is the worst (RMS 0.27, max 0.61 px): its MEI
    // tangential terms have no OPENCV_FISHEYE counterpart.
    EXPECT_LT(out.fit_rms_px, 0.4);
    EXPECT_LT(out.fit_max_px, 1.0);
    EXPECT_LE(out.fit_rms_px, out.fit_max_px);
    // Off the fit's grid, the fitted model stays within the reported error
    // (plus a margin for points between the grid's samples).
    double worst = 0.0;
    int checked = 0;
    for (int i = 0; i < 2000; ++i) {
      const double theta = unit(rng) * options.fisheye_max_angle_deg * M_PI / 180.0;
      const Eigen::Vector3d bearing = test::Direction(theta, 2.0 * M_PI * unit(rng));
      const std::optional<Eigen::Vector2d> pixel = camera.Project(bearing);
      if (!pixel || !camera.IsInImage(*pixel)) continue;
      const Eigen::Vector2d colmap = *ColmapProject(out.camera, bearing);
      worst = std::max(worst, (colmap - (*pixel + Eigen::Vector2d(0.5, 0.5))).norm());
      ++checked;
    }
    EXPECT_GT(checked, 500);
    EXPECT_LT(worst, 1.5 * out.fit_max_px + 0.05);
  }
}

TEST(ColmapCamera, UndistortedPinholeKeepsTheCentralResolutionInsideTheValidArea) {
  ColmapExportOptions options;
  options.fisheye_policy = ColmapFisheyePolicy::kUndistort;
  const Camera kitti = test::Kitti360Image02();
  const ColmapCameraExport out = ConvertCameraToColmap(kitti, 3, options);
  EXPECT_TRUE(out.undistorted);
  EXPECT_EQ(out.camera.model, ColmapCameraModel::kPinhole);
  EXPECT_DOUBLE_EQ(out.camera.params[0], kitti.MeanFocalLength());
  EXPECT_DOUBLE_EQ(out.camera.params[1], kitti.MeanFocalLength());
  // 100 degrees fit well inside the KITTI-360 fisheye: not reduced.
  EXPECT_GE(out.fov_x_deg, 100.0);
  EXPECT_LT(out.fov_x_deg, 100.3);
  EXPECT_NEAR(out.fov_y_deg, out.fov_x_deg, 1e-9);
  EXPECT_EQ(out.camera.width % 2, 0u);
  EXPECT_DOUBLE_EQ(out.camera.params[2], 0.5 * static_cast<double>(out.camera.width));

  // This 640x480 MEI camera cannot hold 100 degrees vertically: the view
  // shrinks until every border pixel of the pinhole sees a pixel of the
  // fisheye image.
  const Camera small = test::MakeCamera("mei_long", CameraModelId::kMei,
                                        {0.9, -0.3, 0.02, 1e-4, -2e-4, 600.0, 601.0, 320.0, 240.0}, 640, 480);
  const ColmapCameraExport reduced = ConvertCameraToColmap(small, 1, options);
  EXPECT_LT(reduced.fov_y_deg, reduced.fov_x_deg);
  const double f = reduced.camera.params[0];
  const double cx = reduced.camera.params[2] - 0.5, cy = reduced.camera.params[3] - 0.5;
  for (uint64_t y = 0; y < reduced.camera.height; ++y) {
    for (uint64_t x : {uint64_t{0}, reduced.camera.width - 1}) {
      const std::optional<Eigen::Vector2d> pixel = small.Project(
          Eigen::Vector3d((static_cast<double>(x) - cx) / f, (static_cast<double>(y) - cy) / f, 1.0));
      ASSERT_TRUE(pixel.has_value());
      EXPECT_TRUE(small.IsInImage(*pixel)) << x << "," << y;
    }
  }
  // And it is the largest such view to about half a degree: one degree more
  // leaves the fisheye image at the top or bottom.
  const double wider = std::tan((0.5 * reduced.fov_y_deg + 1.0) * M_PI / 180.0);
  const std::optional<Eigen::Vector2d> bottom = small.Project(Eigen::Vector3d(0.0, wider, 1.0));
  const std::optional<Eigen::Vector2d> top = small.Project(Eigen::Vector3d(0.0, -wider, 1.0));
  EXPECT_TRUE(!bottom || !top || bottom->y() > small.height - 1.0 || top->y() < 0.0);
  EXPECT_GT(reduced.fov_y_deg, 60.0);
}

// ---------------------------------------------------------------------------
// Model files.

ColmapModel HandMadeModel() {
  ColmapModel model;
  const ColmapCameraModel models[] = {ColmapCameraModel::kPinhole, ColmapCameraModel::kOpenCv,
                                      ColmapCameraModel::kOpenCvFisheye, ColmapCameraModel::kFullOpenCv,
                                      ColmapCameraModel::kSimpleRadial};
  uint32_t id = 1;
  for (ColmapCameraModel camera_model : models) {
    ColmapCamera camera;
    camera.id = id++;
    camera.model = camera_model;
    camera.width = 640 + camera.id;
    camera.height = 480;
    for (int i = 0; i < ColmapCameraModelNumParams(camera_model); ++i)
      camera.params.push_back(0.1 * i + 1.0 / 3.0);
    model.cameras.push_back(camera);
  }
  for (uint32_t i = 1; i <= 3; ++i) {
    ColmapImage image;
    image.id = i * 2;
    image.cam_from_world.rotation = Eigen::Quaterniond(0.5, -0.5, 0.5, 0.5 + 1e-17 * i);
    image.cam_from_world.translation = Eigen::Vector3d(0.1, -2e-30, 1.0 / 7.0);
    image.camera_id = i;
    image.name = "cam" + std::to_string(i) + "/frame_" + std::to_string(i) + ".png";
    if (i != 2) {  // image 4 has no 2-D points
      image.points2d = {{0.5, 1.25}, {1e6 / 3.0, -0.0}, {7.0, 8.0}};
      image.point3d_ids = {kColmapNoPoint3D, 9, 12};
    }
    model.images.push_back(image);
  }
  ColmapPoint3D a;
  a.id = 9;
  a.xyz = Eigen::Vector3d(1.0 / 3.0, -4.0, 1e-300);
  a.rgb = {0, 128, 255};
  a.error = 0.125;
  a.track = {{2, 1}, {6, 1}};
  ColmapPoint3D b = a;
  b.id = 12;
  b.error = 2.0 / 3.0;
  b.track = {{2, 2}, {6, 2}};
  model.points3d = {a, b};
  ColmapRig rig;
  rig.id = 1;
  rig.ref_camera_id = 1;
  rig.sensors = {{2, Rigid3d(Eigen::Quaterniond(0.8, 0.6, 0.0, 0.0), Eigen::Vector3d(0.3, 0.0, -0.1))},
                 {3, std::nullopt}};
  model.rigs = {rig};
  ColmapFrame frame;
  frame.id = 1;
  frame.rig_id = 1;
  frame.rig_from_world = Rigid3d(Eigen::Quaterniond(1.0, 0.0, 0.0, 0.0), Eigen::Vector3d(1.0, 2.0, 3.0));
  frame.data = {{1, 2}, {2, 4}, {3, 6}};
  model.frames = {frame};
  return model;
}

TEST(ColmapModelIo, TextAndBinaryReadBackBitForBit) {
  ScratchDir dir("io_roundtrip");
  const ColmapModel model = HandMadeModel();
  WriteColmapModelText(model, dir.path() / "txt");
  WriteColmapModelBinary(model, dir.path() / "bin");
  EXPECT_EQ(DiffColmapModels(model, ReadColmapModelText(dir.path() / "txt")), "");
  EXPECT_EQ(DiffColmapModels(model, ReadColmapModelBinary(dir.path() / "bin")), "");
  EXPECT_EQ(DiffColmapModels(model, ReadColmapModel(dir.path() / "txt")), "");
  // The quaternions are kept as written, not renormalised.
  EXPECT_EQ(ReadColmapModelBinary(dir.path() / "bin").images[2].cam_from_world.rotation.z(), 0.5 + 3e-17);
  // An image without points keeps its (empty) second line.
  const std::string images_txt = test::ReadBytes(dir.path() / "txt" / "images.txt");
  EXPECT_NE(images_txt.find("cam2/frame_2.png\n\n6 "), std::string::npos) << images_txt;
  EXPECT_NE(images_txt.find("0.5 1.25 -1 "), std::string::npos);
  EXPECT_NE(test::ReadBytes(dir.path() / "txt" / "rigs.txt")
                .find("\n1 3 CAMERA 1 CAMERA 2 1 0.8 0.6 0 0 0.3 0 -0.1 CAMERA 3 0\n"),
            std::string::npos);
  EXPECT_NE(test::ReadBytes(dir.path() / "txt" / "frames.txt")
                .find("\n1 1 1 0 0 0 1 2 3 3 CAMERA 1 2 CAMERA 2 4 CAMERA 3 6\n"),
            std::string::npos);
  // Both present: the binary files win, as in COLMAP.
  WriteColmapModelText(model, dir.path() / "bin");
  EXPECT_EQ(DiffColmapModels(model, ReadColmapModel(dir.path() / "bin")), "");
}

TEST(ColmapModelIo, BinaryLayoutIsColmaps) {
  ScratchDir dir("io_layout");
  ColmapModel model;
  model.cameras.push_back({7, ColmapCameraModel::kPinhole, 640, 480, {1.0, 2.0, 3.0, 4.0}});
  ColmapImage image;
  image.id = 3;
  image.camera_id = 7;
  image.name = "a/b.png";
  image.points2d = {{1.0, 2.0}};
  image.point3d_ids = {kColmapNoPoint3D};
  model.images.push_back(image);
  WriteColmapModelBinary(model, dir.path());
  // u64 n; u32 id, i32 model, u64 w, u64 h, 4 x f64.
  const std::string cameras = test::ReadBytes(dir.path() / "cameras.bin");
  ASSERT_EQ(cameras.size(), 8u + 4 + 4 + 8 + 8 + 4 * 8);
  EXPECT_EQ(cameras.substr(0, 12), std::string("\x01\0\0\0\0\0\0\0\x07\0\0\0", 12));
  EXPECT_EQ(cameras[12], 1);  // PINHOLE
  // u64 n; u32 id, 7 x f64, u32 camera, name NUL, u64 n2d, (f64, f64, u64).
  const std::string images = test::ReadBytes(dir.path() / "images.bin");
  EXPECT_EQ(images.size(), 8u + 4 + 56 + 4 + 8 + 8 + 24);
  EXPECT_EQ(images.substr(images.size() - 8), std::string(8, '\xff'));  // no 3-D point
  EXPECT_EQ(test::ReadBytes(dir.path() / "points3D.bin"), std::string(8, '\0'));
  EXPECT_FALSE(fs::exists(dir.path() / "rigs.bin"));
}

TEST(ColmapModelIo, ReadersNameTheFileLineAndField) {
  ScratchDir dir("io_errors");
  WriteColmapModelText(HandMadeModel(), dir.path());
  const auto expect_error = [&](const std::string& file, const std::string& content,
                                const std::string& expected) {
    const fs::path path = dir.path() / file;
    const std::string original = test::ReadBytes(path);
    WriteFileAtomic(path, content);
    try {
      ReadColmapModelText(dir.path());
      ADD_FAILURE() << "no error for " << file;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    WriteFileAtomic(path, original);
  };
  expect_error("cameras.txt", "# c\n\n1 PINHOLE 640 480 1 2 3\n",
               "cameras.txt:3: PARAMS: PINHOLE has 4 parameters");
  expect_error("cameras.txt", "1 PINHOLE_X 640 480 1 2 3 4\n", "cameras.txt:1: MODEL: unknown camera model");
  expect_error("images.txt", "2 x 0 0 0 0 0 0 1 a.png\n\n",
               "images.txt:1: QW QX QY QZ TX TY TZ: expected a finite number, got 'x'");
  expect_error("images.txt", "2 1 0 0 0 0 0 0 1 a.png\n1 2\n", "images.txt:2: POINTS2D: expected triplets");
  expect_error("points3D.txt", "9 1 2 3 0 0 300 0.5 2 1\n", "points3D.txt:1: R G B");
  expect_error("rigs.txt", "1 2 CAMERA 1 IMU 2 0\n", "rigs.txt:1: SENSOR_TYPE: only CAMERA sensors");

  WriteColmapModelBinary(HandMadeModel(), dir.path() / "bin");
  const fs::path points = dir.path() / "bin" / "points3D.bin";
  const std::string bytes = test::ReadBytes(points);
  WriteFileAtomic(points, bytes.substr(0, bytes.size() - 3));
  try {
    ReadColmapModelBinary(dir.path() / "bin");
    ADD_FAILURE() << "no error for a truncated points3D.bin";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("points3D.bin"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadColmapModel(dir.path() / "none"), InputError);
}

// ---------------------------------------------------------------------------
// Export.

TEST(ColmapExport, CountsIdsNamesAndPixelsFollowTheMap) {
  ScratchDir dir("export_counts");
  Synthetic s = MakeSynthetic();
  // Keyframe 2: camera 1 has no image and no observation (no COLMAP image);
  // keyframe 3: camera 0 has observations but no image (a placeholder name).
  s.map.keyframes[2].images[1].clear();
  auto& keyframe2 = s.map.keyframes[2].observations;
  keyframe2.erase(std::remove_if(keyframe2.begin(), keyframe2.end(),
                                 [](const MapObservation& o) { return o.camera == 1; }),
                  keyframe2.end());
  s.map.keyframes[3].images[0].clear();
  const ColmapExportOptions options = NoImages();
  const ColmapExportReport report =
      WriteColmapModel(s.rig, s.map, dir.path() / "dataset", options, dir.path() / "out");
  EXPECT_EQ(report.model_dir, dir.path() / "out" / "sparse" / "0");
  EXPECT_EQ(report.text_dir, dir.path() / "out" / "sparse_txt" / "0");
  EXPECT_TRUE(report.image_dir.empty());
  const ColmapModel model = ReadColmapModelBinary(report.model_dir);
  EXPECT_EQ(DiffColmapModels(model, ReadColmapModelText(report.text_dir)), "");
  EXPECT_FALSE(fs::exists(dir.path() / "out" / "images"));

  // Expected from the map, independently of the exporter.
  std::map<int64_t, int> kept_per_landmark;
  int64_t kept = 0, dropped = 0;
  for (const MapKeyframe& keyframe : s.map.keyframes) {
    for (const MapObservation& o : keyframe.observations) {
      const bool keep = Kept(s.rig, keyframe, o, Landmark(s.map, o.landmark_id).position_world,
                             options.fisheye_max_angle_deg);
      (keep ? kept : dropped) += 1;
      if (keep) ++kept_per_landmark[o.landmark_id];
    }
  }
  std::set<int64_t> point_landmarks;
  int64_t observations = 0;
  for (const auto& [id, count] : kept_per_landmark) {
    if (count >= 2) {
      point_landmarks.insert(id);
      observations += count;
    }
  }
  EXPECT_GT(dropped, 0);  // KB points beyond 90 degrees, MEI points beyond 85
  EXPECT_EQ(report.observations_dropped, dropped);
  EXPECT_EQ(report.cameras, 3);
  EXPECT_EQ(report.images, 6 * 3 - 1);
  EXPECT_EQ(report.points, static_cast<int>(point_landmarks.size()));
  EXPECT_EQ(report.observations, observations);
  EXPECT_EQ(report.landmarks_dropped, static_cast<int64_t>(s.map.landmarks.size() - point_landmarks.size()));
  EXPECT_EQ(report.images_without_source, 1);
  ASSERT_EQ(model.cameras.size(), 3u);
  ASSERT_EQ(model.images.size(), 17u);
  ASSERT_EQ(static_cast<int>(model.points3d.size()), report.points);
  EXPECT_EQ(model.NumObservations(), observations);
  EXPECT_EQ(model.cameras[0].model, ColmapCameraModel::kPinhole);
  EXPECT_EQ(model.cameras[1].model, ColmapCameraModel::kOpenCvFisheye);
  EXPECT_EQ(model.cameras[2].model, ColmapCameraModel::kOpenCvFisheye);

  // Images in keyframe then camera order, ids from 1; names relative to the
  // dataset root; 2-D points = observed pixels + 0.5, in the map's order.
  uint32_t expected_id = 1;
  for (size_t k = 0; k < s.map.keyframes.size(); ++k) {
    const MapKeyframe& keyframe = s.map.keyframes[k];
    for (int c = 0; c < 3; ++c) {
      if (k == 2 && c == 1) continue;
      const ColmapImage* image = model.FindImage(expected_id);
      ASSERT_NE(image, nullptr);
      EXPECT_EQ(image->camera_id, static_cast<uint32_t>(c + 1));
      const std::string expected_name = k == 3 && c == 0
                                            ? "cam0_pinhole/" + test::FrameName(keyframe.frame_index)
                                            : keyframe.images[c].generic_string();
      EXPECT_EQ(image->name, expected_name);
      const Rigid3d cam_from_world = s.rig.cameras[c].cam_from_rig * keyframe.world_from_rig.Inverse();
      EXPECT_LT(image->cam_from_world.rotation.angularDistance(cam_from_world.rotation), 1e-12);
      EXPECT_LT((image->cam_from_world.translation - cam_from_world.translation).norm(), 1e-12);
      EXPECT_GE(image->cam_from_world.rotation.w(), 0.0);
      size_t i = 0;
      for (const MapObservation& o : keyframe.observations) {
        if (o.camera != c || point_landmarks.count(o.landmark_id) == 0 ||
            !Kept(s.rig, keyframe, o, Landmark(s.map, o.landmark_id).position_world,
                  options.fisheye_max_angle_deg))
          continue;
        ASSERT_LT(i, image->points2d.size());
        EXPECT_EQ(image->points2d[i], o.pixel + Eigen::Vector2d(0.5, 0.5));
        EXPECT_EQ(image->point3d_ids[i], static_cast<uint64_t>(o.landmark_id + 1));
        ++i;
      }
      EXPECT_EQ(i, image->points2d.size());
      ++expected_id;
    }
  }
  // Points: id = landmark id + 1, the landmark's position, grey, and a track
  // that points back at the 2-D points.
  for (const ColmapPoint3D& point : model.points3d) {
    ASSERT_EQ(point_landmarks.count(static_cast<int64_t>(point.id) - 1), 1u);
    EXPECT_EQ(point.xyz, Landmark(s.map, static_cast<int64_t>(point.id) - 1).position_world);
    EXPECT_EQ(point.rgb, (std::array<uint8_t, 3>{128, 128, 128}));
    EXPECT_EQ(static_cast<int>(point.track.size()), kept_per_landmark[static_cast<int64_t>(point.id) - 1]);
    for (const ColmapTrackElement& element : point.track) {
      const ColmapImage* image = model.FindImage(element.image_id);
      ASSERT_NE(image, nullptr);
      ASSERT_LT(element.point2d_idx, image->point3d_ids.size());
      EXPECT_EQ(image->point3d_ids[element.point2d_idx], point.id);
    }
  }
}

TEST(ColmapExport, ErrorsAreReprojectionErrorsThroughTheWrittenCameras) {
  ScratchDir dir("export_errors");
  const Synthetic s = MakeSynthetic();
  const ColmapExportReport report =
      WriteColmapModel(s.rig, s.map, dir.path() / "dataset", NoImages(), dir.path() / "out");
  const ColmapModel model = ReadColmapModel(report.model_dir);
  const double mei_fit_max = report.camera_exports[2].fit_max_px;
  double sum = 0.0;
  int exact_points = 0;
  for (const ColmapPoint3D& point : model.points3d) {
    double error = 0.0;
    bool seen_by_mei = false;
    for (const ColmapTrackElement& element : point.track) {
      const ColmapImage& image = *model.FindImage(element.image_id);
      const ColmapCamera& camera = *model.FindCamera(image.camera_id);
      error +=
          (*ColmapProject(camera, image.cam_from_world * point.xyz) - image.points2d[element.point2d_idx])
              .norm();
      seen_by_mei |= image.camera_id == 3;
    }
    error /= static_cast<double>(point.track.size());
    EXPECT_NEAR(point.error, error, 1e-12);
    // Exact data: zero through the exact models, the fit's error through the fitted one.
    if (!seen_by_mei) {
      EXPECT_LT(point.error, 1e-9);
      ++exact_points;
    }
    EXPECT_LT(point.error, mei_fit_max + 1e-9);
    sum += point.error;
  }
  EXPECT_GT(exact_points, 50);
  EXPECT_NEAR(report.mean_reprojection_error_px, sum / static_cast<double>(model.points3d.size()), 1e-12);

  // Without the MEI camera everything is exact.
  Rig rig = s.rig;
  rig.cameras.pop_back();
  SparseMap map = test::ProjectedMap(rig, test::KeyframePoses(6), test::RandomPoints(300, 1));
  const ColmapExportReport exact =
      WriteColmapModel(rig, map, dir.path() / "dataset", NoImages(), dir.path() / "exact");
  EXPECT_GT(exact.points, 100);
  EXPECT_LT(exact.mean_reprojection_error_px, 1e-10);
}

TEST(ColmapExport, RigAndFrameFilesComposeToTheImagePoses) {
  ScratchDir dir("export_rig");
  const Synthetic s = MakeSynthetic(100, 4);
  const ColmapExportReport report =
      WriteColmapModel(s.rig, s.map, dir.path() / "dataset", NoImages(), dir.path() / "out");
  const ColmapModel model = ReadColmapModel(report.model_dir);
  ASSERT_EQ(model.rigs.size(), 1u);
  const ColmapRig& rig = model.rigs[0];
  EXPECT_EQ(rig.ref_camera_id, 1u);
  ASSERT_EQ(rig.sensors.size(), 2u);
  ASSERT_EQ(model.frames.size(), 4u);
  for (const ColmapFrame& frame : model.frames) {
    EXPECT_EQ(frame.rig_id, 1u);
    ASSERT_EQ(frame.data.size(), 3u);
    for (const ColmapFrameData& data : frame.data) {
      const ColmapImage& image = *model.FindImage(static_cast<uint32_t>(data.image_id));
      EXPECT_EQ(image.camera_id, data.camera_id);
      const Rigid3d sensor_from_rig =
          data.camera_id == 1 ? Rigid3d() : *rig.sensors[data.camera_id - 2].sensor_from_rig;
      const Rigid3d cam_from_world = sensor_from_rig * frame.rig_from_world;
      EXPECT_LT(cam_from_world.rotation.angularDistance(image.cam_from_world.rotation), 1e-12);
      EXPECT_LT((cam_from_world.translation - image.cam_from_world.translation).norm(), 1e-12);
    }
  }
  // Frame ids are keyframe indices + 1; without rig files there are none.
  EXPECT_EQ(model.frames.back().id, 4u);
  ColmapExportOptions options = NoImages();
  options.write_rig_files = false;
  options.format = ColmapModelFormat::kText;
  const ColmapExportReport plain =
      WriteColmapModel(s.rig, s.map, dir.path() / "dataset", options, dir.path() / "plain");
  EXPECT_EQ(plain.text_dir, plain.model_dir);
  EXPECT_TRUE(fs::exists(plain.model_dir / "cameras.txt"));
  EXPECT_FALSE(fs::exists(plain.model_dir / "rigs.txt"));
  EXPECT_FALSE(fs::exists(plain.model_dir / "cameras.bin"));
  EXPECT_FALSE(fs::exists(dir.path() / "plain" / "sparse_txt"));
  EXPECT_TRUE(ReadColmapModel(plain.model_dir).rigs.empty());
}

TEST(ColmapExport, MinTrackLengthDecidesWhichLandmarksBecomePoints) {
  ScratchDir dir("export_tracks");
  const Synthetic s = MakeSynthetic(200, 3);
  std::vector<int> points;
  for (int min_track : {1, 2, 4}) {
    ColmapExportOptions options = NoImages();
    options.min_track_length = min_track;
    const ColmapExportReport report = WriteColmapModel(s.rig, s.map, dir.path() / "dataset", options,
                                                       dir.path() / ("out" + std::to_string(min_track)));
    const ColmapModel model = ReadColmapModel(report.model_dir);
    for (const ColmapPoint3D& point : model.points3d)
      EXPECT_GE(static_cast<int>(point.track.size()), min_track);
    EXPECT_EQ(report.points + report.landmarks_dropped, static_cast<int64_t>(s.map.landmarks.size()));
    points.push_back(report.points);
  }
  EXPECT_GT(points[0], points[1]);
  EXPECT_GT(points[1], points[2]);
}

TEST(ColmapExport, ImagesAreLinkedCopiedOrRemapped) {
  ScratchDir dir("export_images");
  const Synthetic s = MakeSynthetic(150, 3);
  const fs::path root = dir.path() / "dataset";
  WriteImages(s.rig, s.map, root, NoiseImage);
  const size_t num_images = s.map.keyframes.size() * 3;

  ColmapExportOptions options;
  options.image_mode = ColmapImageMode::kLink;
  const ColmapExportReport linked = WriteColmapModel(s.rig, s.map, root, options, dir.path() / "link");
  EXPECT_EQ(linked.images_written, static_cast<int>(num_images));
  EXPECT_EQ(linked.image_dir, dir.path() / "link" / "images");
  for (const ColmapImage& image : ReadColmapModel(linked.model_dir).images) {
    const fs::path path = linked.image_dir / image.name;
    ASSERT_TRUE(fs::is_symlink(path)) << path;
    EXPECT_EQ(fs::read_symlink(path), fs::absolute(root / image.name).lexically_normal());
    EXPECT_TRUE(fs::exists(path));  // resolves
  }

  options.image_mode = ColmapImageMode::kCopy;
  const ColmapExportReport copied = WriteColmapModel(s.rig, s.map, root, options, dir.path() / "copy");
  for (const ColmapImage& image : ReadColmapModel(copied.model_dir).images) {
    const fs::path path = copied.image_dir / image.name;
    EXPECT_FALSE(fs::is_symlink(path));
    EXPECT_EQ(test::ReadBytes(path), test::ReadBytes(root / image.name)) << path;
  }

  options.fisheye_policy = ColmapFisheyePolicy::kUndistort;
  const ColmapExportReport undistorted =
      WriteColmapModel(s.rig, s.map, root, options, dir.path() / "undistort");
  const ColmapModel model = ReadColmapModel(undistorted.model_dir);
  EXPECT_EQ(model.cameras[2].model, ColmapCameraModel::kPinhole);
  EXPECT_TRUE(undistorted.camera_exports[2].undistorted);
  for (const ColmapImage& image : model.images) {
    const cv::Mat written = cv::imread((undistorted.image_dir / image.name).string(), cv::IMREAD_UNCHANGED);
    const ColmapCamera& camera = *model.FindCamera(image.camera_id);
    ASSERT_FALSE(written.empty());
    EXPECT_EQ(written.cols, static_cast<int>(camera.width));
    EXPECT_EQ(written.rows, static_cast<int>(camera.height));
    EXPECT_EQ(written.type(), CV_8UC1);
    if (image.camera_id != 3) {
      EXPECT_EQ(test::ReadBytes(undistorted.image_dir / image.name), test::ReadBytes(root / image.name));
    }
  }
}

TEST(ColmapExport, UndistortedImagesAndObservationsAgree) {
  // Bright blobs at known bearings of a MEI camera; after the export the
  // blobs of the remapped image sit at the written 2-D points.
  ScratchDir dir("export_remap");
  Rig rig;
  rig.cameras.push_back(ScaledCamera(test::Kitti360Image02(), 0.4));
  const Camera& camera = rig.cameras[0];
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 12; ++i) {
    const double theta = (5.0 + 3.5 * i) * M_PI / 180.0;
    points.push_back(4.0 * test::Direction(theta, 0.9 * i));
  }
  SparseMap map = test::ProjectedMap(rig, {Rigid3d(), Rigid3d()}, points);
  cv::Mat image(camera.height, camera.width, CV_32FC1, cv::Scalar(0));
  for (const MapObservation& o : map.keyframes[0].observations) {
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        const double d2 = (Eigen::Vector2d(x, y) - o.pixel).squaredNorm();
        image.at<float>(y, x) += static_cast<float>(250.0 * std::exp(-d2 / (2.0 * 1.5 * 1.5)));
      }
    }
  }
  cv::Mat image8;
  image.convertTo(image8, CV_8UC1);
  const fs::path root = dir.path() / "dataset";
  WriteImages(rig, map, root, [&](const Camera&) { return image8; });

  ColmapExportOptions options;
  options.image_mode = ColmapImageMode::kCopy;
  options.fisheye_policy = ColmapFisheyePolicy::kUndistort;
  const ColmapExportReport report = WriteColmapModel(rig, map, root, options, dir.path() / "out");
  const ColmapModel model = ReadColmapModel(report.model_dir);
  ASSERT_EQ(model.images.size(), 2u);
  EXPECT_EQ(model.images[0].points2d.size(), points.size());
  const cv::Mat remapped =
      cv::imread((report.image_dir / model.images[0].name).string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(remapped.empty());
  for (size_t i = 0; i < model.images[0].points2d.size(); ++i) {
    const Eigen::Vector2d expected =
        model.images[0].points2d[i] - Eigen::Vector2d(0.5, 0.5);  // OpenCV convention
    // Intensity-weighted centroid in a window around it.
    double sum = 0.0;
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    const int x0 = static_cast<int>(std::lround(expected.x())),
              y0 = static_cast<int>(std::lround(expected.y()));
    for (int y = y0 - 6; y <= y0 + 6; ++y) {
      for (int x = x0 - 6; x <= x0 + 6; ++x) {
        const double value = remapped.at<uint8_t>(y, x);
        sum += value;
        centroid += value * Eigen::Vector2d(x, y);
      }
    }
    ASSERT_GT(sum, 0.0);
    centroid /= sum;
    EXPECT_LT((centroid - expected).norm(), 0.2)
        << i << ": " << centroid.transpose() << " vs " << expected.transpose();
    // And the 2-D point is the pinhole projection of the landmark: exact data, zero error.
    const ColmapPoint3D& point = *model.FindPoint3D(model.images[0].point3d_ids[i]);
    EXPECT_LT(point.error, 1e-6);
  }
}

TEST(ColmapExport, ColorsAreSampledFromTheImages) {
  ScratchDir dir("export_colors");
  const Synthetic s = MakeSynthetic(80, 3);
  const fs::path root = dir.path() / "dataset";
  // Colour images of one colour (BGR 10, 20, 200): every point is RGB 200, 20, 10.
  WriteImages(s.rig, s.map, root,
              [](const Camera& c) { return cv::Mat(c.height, c.width, CV_8UC3, cv::Scalar(10, 20, 200)); });
  ColmapExportOptions options;
  options.image_mode = ColmapImageMode::kNone;
  const ColmapExportReport report = WriteColmapModel(s.rig, s.map, root, options, dir.path() / "color");
  EXPECT_EQ(report.images_without_color, 0);
  for (const ColmapPoint3D& point : ReadColmapModel(report.model_dir).points3d)
    EXPECT_EQ(point.rgb, (std::array<uint8_t, 3>{200, 20, 10}));

  // Grey images: grey points. Unreadable images: 128 and a note.
  WriteImages(s.rig, s.map, root,
              [](const Camera& c) { return cv::Mat(c.height, c.width, CV_8UC1, cv::Scalar(77)); });
  fs::remove(root / s.map.keyframes[0].images[0]);
  const ColmapExportReport grey = WriteColmapModel(s.rig, s.map, root, options, dir.path() / "grey");
  EXPECT_EQ(grey.images_without_color, 1);
  EXPECT_NE(DescribeColmapExport(grey).find("could not be read for colours"), std::string::npos);
  for (const ColmapPoint3D& point : ReadColmapModel(grey.model_dir).points3d) {
    bool only_first_image = true;
    for (const ColmapTrackElement& element : point.track) only_first_image &= element.image_id == 1;
    EXPECT_EQ(point.rgb, only_first_image ? (std::array<uint8_t, 3>{128, 128, 128})
                                          : (std::array<uint8_t, 3>{77, 77, 77}));
  }
}

TEST(ColmapExport, ByteIdenticalAtAnyThreadCount) {
  ScratchDir dir("export_determinism");
  const Synthetic s = MakeSynthetic(150, 3);
  const fs::path root = dir.path() / "dataset";
  WriteImages(s.rig, s.map, root, NoiseImage);
  ColmapExportOptions options;
  options.image_mode = ColmapImageMode::kCopy;
  options.fisheye_policy = ColmapFisheyePolicy::kUndistort;
  options.threads = 1;
  WriteColmapModel(s.rig, s.map, root, options, dir.path() / "a");
  options.threads = 3;
  WriteColmapModel(s.rig, s.map, root, options, dir.path() / "b");
  const auto a = TreeContents(dir.path() / "a");
  const auto b = TreeContents(dir.path() / "b");
  EXPECT_EQ(a.size(), 5u + 5u + 9u);  // binary and text model files, 3 keyframes x 3 images
  EXPECT_TRUE(a == b);
}

TEST(ColmapExport, AFailedExportLeavesNothingBehind) {
  ScratchDir dir("export_failure");
  const Synthetic s = MakeSynthetic(50, 2);
  ColmapExportOptions options;
  options.image_mode = ColmapImageMode::kLink;  // the images do not exist
  try {
    WriteColmapModel(s.rig, s.map, dir.path() / "dataset", options, dir.path() / "out");
    ADD_FAILURE() << "no error for missing images";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("image not found"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.path() / "out"));
  EXPECT_TRUE(fs::is_empty(dir.path()));  // no staging folder either
}

TEST(ColmapExport, ReplacesAnExistingFolderOnlyWhenAsked) {
  ScratchDir dir("export_overwrite");
  const Synthetic s = MakeSynthetic(50, 2);
  fs::create_directories(dir.path() / "out");
  WriteFileAtomic(dir.path() / "out" / "old.txt", "old");
  EXPECT_THROW(WriteColmapModel(s.rig, s.map, "", NoImages(), dir.path() / "out"), InputError);
  EXPECT_TRUE(fs::exists(dir.path() / "out" / "old.txt"));
  ColmapExportOptions options = NoImages();
  options.overwrite = true;
  WriteColmapModel(s.rig, s.map, "", options, dir.path() / "out");
  EXPECT_FALSE(fs::exists(dir.path() / "out" / "old.txt"));
  EXPECT_TRUE(fs::exists(dir.path() / "out" / "sparse" / "0" / "images.bin"));
}

TEST(ColmapExport, ImageNamesStayBelowTheDatasetRootAndUnique) {
  ScratchDir dir("export_names");
  Synthetic s = MakeSynthetic(50, 3);
  const fs::path root = dir.path() / "dataset";
  // Absolute under the root: relative name. Outside the root: <camera>/<file>;
  // the same file name twice: the frame index in front. Blanks become '_'.
  s.map.keyframes[0].images[0] = root / "images" / "cam0_pinhole" / "a.png";
  s.map.keyframes[1].images[0] = dir.path() / "elsewhere" / "x.png";
  s.map.keyframes[2].images[0] = dir.path() / "other" / "x.png";
  s.map.keyframes[0].images[1] = "images/cam1_kb/with blank.png";
  const ColmapExportReport report = WriteColmapModel(s.rig, s.map, root, NoImages(), dir.path() / "out");
  const ColmapModel model = ReadColmapModel(report.model_dir);
  EXPECT_EQ(model.images[0].name, "images/cam0_pinhole/a.png");
  EXPECT_EQ(model.images[1].name, "images/cam1_kb/with_blank.png");
  EXPECT_EQ(model.images[3].name, "cam0_pinhole/x.png");
  EXPECT_EQ(model.images[6].name, "cam0_pinhole/000009_x.png");
  EXPECT_NE(DescribeColmapExport(report).find("blanks in image names"), std::string::npos);
}

TEST(ColmapExport, RejectsMapsThatDoNotFitTheRig) {
  ScratchDir dir("export_bad_map");
  const Synthetic good = MakeSynthetic(50, 2);
  const auto expect_error = [&](const SparseMap& map, const std::string& expected) {
    try {
      WriteColmapModel(good.rig, map, "", NoImages(), dir.path() / "out");
      ADD_FAILURE() << "no error, expected: " << expected;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(dir.path() / "out"));
  };
  SparseMap map = good.map;
  map.keyframes[1].observations[0].landmark_id = 11;
  expect_error(map, "keyframes[1] (frame 7): landmark 11 is not in the map's landmarks");
  map = good.map;
  map.keyframes[0].observations[0].camera = 3;
  expect_error(map, "observation of camera 3, the rig has 3");
  map = good.map;
  map.keyframes[0].observations.push_back(map.keyframes[0].observations[0]);
  expect_error(map, "observed twice");
  map = good.map;
  map.keyframes[0].images.pop_back();
  expect_error(map, "2 image paths for 3 cameras");
  map = good.map;
  std::swap(map.landmarks[0], map.landmarks[1]);
  expect_error(map, "ids must be strictly ascending");
}

TEST(ColmapExport, OptionsAreCheckedByName) {
  const auto expect_error = [](ColmapExportOptions options, const std::string& expected) {
    try {
      options.Check();
      ADD_FAILURE() << "no error, expected: " << expected;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  ColmapExportOptions options;
  EXPECT_NO_THROW(options.Check());
  options.fisheye_max_angle_deg = 95.0;
  expect_error(options, "/colmap/fisheye_max_angle_deg: must be in [1, 89], got 95");
  options = ColmapExportOptions();
  options.min_track_length = 0;
  expect_error(options, "/colmap/min_track_length");
  options = ColmapExportOptions();
  options.undistort_fov_deg = 180.0;
  expect_error(options, "/colmap/undistort_fov_deg");

  // Undistorted cameras need their images written.
  ScratchDir dir("export_usage");
  const Synthetic s = MakeSynthetic(30, 2);
  options = NoImages();
  options.fisheye_policy = ColmapFisheyePolicy::kUndistort;
  EXPECT_THROW(WriteColmapModel(s.rig, s.map, "", options, dir.path() / "out"), UsageError);
}

}  // namespace
}  // namespace mcvo
