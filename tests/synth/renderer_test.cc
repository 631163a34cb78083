// Renderer: agreement with cv::projectPoints, determinism (threads, seeds),
// the photometric effects, anti-aliasing, option checks.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "camera/test_cameras.h"
#include "mcvo/synth/renderer.h"
#include "mcvo/util/error.h"
#include "synth/marker_scene.h"
#include "synth/street_scene.h"

namespace mcvo::synth {
namespace {

// Camera looking along world +x (rig = world axes): x_cam = -y, y_cam = -z, z_cam = x.
Rigid3d ForwardCamFromRig() {
  Eigen::Matrix3d cam_from_rig;
  cam_from_rig << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  return Rigid3d(cam_from_rig, Eigen::Vector3d::Zero());
}

Rig PinholeRig(int width = 320, int height = 240, double f = 250.0) {
  Camera camera = test::MakeCamera("front", CameraModelId::kPinhole,
                                   {f, f, 0.5 * width - 0.5, 0.5 * height - 0.5}, width, height);
  camera.cam_from_rig = ForwardCamFromRig();
  Camera side = camera;  // looking along world -y
  side.name = "right";
  side.cam_from_rig = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(-0.5 * M_PI, Eigen::Vector3d::UnitY())),
                              Eigen::Vector3d::Zero()) *
                      ForwardCamFromRig();
  Rig rig;
  rig.cameras = {camera, side};
  return rig;
}

using test::MakeQuad;

// A street along +x: asphalt, two facades 8 m to the sides, a poster at the
// end, and a panel moving across the street.
Scene StreetScene() {
  Scene scene;
  test::AddStreetQuads(&scene);
  MovingObject panel;
  panel.quads_in_object.push_back(MakeQuad({0, -1, 0}, {0, 2, 0}, {0, 0, 1.5}, Material::kMetal, 5));
  panel.start_in_world = Eigen::Vector3d(20, -6, 0);
  panel.end_in_world = Eigen::Vector3d(20, 6, 0);
  panel.speed_mps = 3.0;
  scene.AddMovingObject(panel);
  scene.Build();
  return scene;
}

Rigid3d RigAt(double x, double y = 0.0) {
  return Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(x, y, 1.5));
}

cv::Mat Render(const Scene& scene, const Rig& rig, int camera, const RenderOptions& options, int frame = 0,
               int64_t t_ns = 0, double x = 0.0) {
  return RenderImage(
      scene, rig, camera, [&](int64_t) { return RigAt(x); }, t_ns, frame, options);
}

bool Identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && a.isContinuous() && b.isContinuous() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

double MeanAbsDifference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  return cv::mean(diff)[0];
}

TEST(Renderer, PinholeAgreesWithOpenCvProjectPoints) {
  Camera camera =
      test::MakeCamera("pinhole", CameraModelId::kPinhole, {430.0, 425.0, 318.4, 243.1}, 640, 480);
  camera.cam_from_rig = test::TestCamFromRig();
  const Rigid3d world_from_rig = test::TestWorldFromRig();
  const test::MarkerScene markers = test::MakeMarkerScene(camera, world_from_rig, 60.0);
  ASSERT_GE(markers.markers.size(), 12u);
  Rig rig;
  rig.cameras = {camera};
  const cv::Mat image = RenderImageAtPoses(markers.scene, rig, 0, {world_from_rig}, {0}, 0, RenderOptions());

  // OpenCV: x = K [R | t] X with R, t = cam_from_world.
  const Rigid3d cam_from_world = camera.cam_from_rig * world_from_rig.Inverse();
  const Eigen::Matrix3d r = cam_from_world.RotationMatrix();
  const cv::Matx33d rotation(r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1), r(2, 2));
  cv::Vec3d rvec;
  cv::Rodrigues(rotation, rvec);
  const cv::Vec3d tvec(cam_from_world.translation.x(), cam_from_world.translation.y(),
                       cam_from_world.translation.z());
  const cv::Matx33d k(430.0, 0.0, 318.4, 0.0, 425.0, 243.1, 0.0, 0.0, 1.0);
  std::vector<cv::Point3d> points;
  for (const test::Marker& marker : markers.markers) {
    points.emplace_back(marker.point_in_world.x(), marker.point_in_world.y(), marker.point_in_world.z());
  }
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(points, rvec, tvec, k, cv::noArray(), pixels);
  double worst = 0.0;
  for (size_t i = 0; i < points.size(); ++i) {
    const auto centroid = test::MarkerCentroid(image, camera, world_from_rig, markers.markers[i]);
    ASSERT_TRUE(centroid);
    const double error = std::hypot(centroid->x() - pixels[i].x, centroid->y() - pixels[i].y);
    EXPECT_LT(error, 0.5) << "marker " << i;
    worst = std::max(worst, error);
  }
  std::printf("rendered centroid vs cv::projectPoints, %zu markers: worst %.4f px\n", points.size(), worst);
}

TEST(Renderer, ByteIdenticalForAnyThreadCountAndRepeatedRuns) {
  const Scene scene = StreetScene();
  const Rig rig = PinholeRig();
  RenderOptions options;
  options.effects.noise_sigma = 3.0;
  options.effects.vignetting = true;
  options.effects.exposure_changes = true;
  options.effects.motion_blur_samples = 3;
  options.seed = 7;
  for (int camera = 0; camera < 2; ++camera) {
    options.adaptive_supersampling = camera == 0;
    options.threads = 1;
    const cv::Mat one = Render(scene, rig, camera, options, 3, 2'500'000'000);
    options.threads = 2;
    const cv::Mat two = Render(scene, rig, camera, options, 3, 2'500'000'000);
    options.threads = 5;
    const cv::Mat five = Render(scene, rig, camera, options, 3, 2'500'000'000);
    ClearRenderCache();  // a rebuilt bearing cache gives the same image
    const cv::Mat again = Render(scene, rig, camera, options, 3, 2'500'000'000);
    EXPECT_TRUE(Identical(one, two)) << camera;
    EXPECT_TRUE(Identical(one, five)) << camera;
    EXPECT_TRUE(Identical(one, again)) << camera;
    EXPECT_GT(cv::countNonZero(one), one.total() / 2);
  }
}

// Adaptive traversal intersects the samples of edge-free pixels with the
// quad's plane directly: the same image as casting every sample, but for
// features narrower than the gap between pixel centres (none here).
TEST(Renderer, AdaptiveTraversalGivesTheSameImage) {
  const Scene scene = StreetScene();
  Rig rig = PinholeRig();
  rig.cameras.push_back(ScaledCamera(test::Kitti360Image02(), 0.25));
  rig.cameras.back().cam_from_rig = ForwardCamFromRig();
  RenderOptions options;
  options.effects.motion_blur_samples = 2;
  for (int camera = 0; camera < rig.NumCameras(); ++camera) {
    options.adaptive_supersampling = true;
    const cv::Mat adaptive = Render(scene, rig, camera, options, 0, 1'000'000'000);
    options.adaptive_supersampling = false;
    const cv::Mat every_sample = Render(scene, rig, camera, options, 0, 1'000'000'000);
    cv::Mat diff;
    cv::absdiff(adaptive, every_sample, diff);
    double largest = 0.0;
    cv::minMaxLoc(diff, nullptr, &largest);
    std::printf("camera %d: adaptive vs every sample: %d pixels differ, largest difference %.0f\n", camera,
                cv::countNonZero(diff), largest);
    EXPECT_LT(cv::countNonZero(diff > 1), diff.total() / 10000 + 1) << camera;
  }
}

TEST(Renderer, NoiseDependsOnTheSeedNotTheMean) {
  const Scene scene = StreetScene();
  const Rig rig = PinholeRig();
  RenderOptions options;
  const cv::Mat clean = Render(scene, rig, 0, options);
  options.effects.noise_sigma = 4.0;
  options.seed = 1;
  const cv::Mat noisy_a = Render(scene, rig, 0, options);
  options.seed = 2;
  const cv::Mat noisy_b = Render(scene, rig, 0, options);
  cv::Mat diff = noisy_a != noisy_b;
  EXPECT_GT(cv::countNonZero(diff), 0.7 * diff.total());
  // The noise has zero mean (clamping aside: the street is mid-grey).
  EXPECT_NEAR(cv::mean(noisy_a)[0], cv::mean(clean)[0], 0.3);
  EXPECT_NEAR(cv::mean(noisy_b)[0], cv::mean(clean)[0], 0.3);
  // Standard deviation of the noise: sigma * sqrt(1 + v / 255) for v ~ 100..200.
  cv::Mat residual;
  cv::subtract(noisy_a, clean, residual, cv::noArray(), CV_32F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(residual, mean, stddev);
  EXPECT_GT(stddev[0], 3.8);
  EXPECT_LT(stddev[0], 4.0 * std::sqrt(2.0) + 0.3);
}

TEST(Renderer, BlackoutIsAllZeroForItsCameraAndFramesOnly) {
  const Scene scene = StreetScene();
  const Rig rig = PinholeRig();
  RenderOptions options;
  options.effects.blackout_camera = 1;
  options.effects.blackout_first_frame = 4;
  options.effects.blackout_num_frames = 3;
  options.effects.noise_sigma = 2.0;
  for (int frame = 2; frame < 9; ++frame) {
    const bool black = frame >= 4 && frame < 7;
    const int lit = cv::countNonZero(Render(scene, rig, 1, options, frame));
    if (black) {
      EXPECT_EQ(lit, 0) << frame;
    } else {
      EXPECT_GT(lit, 0) << frame;
    }
    EXPECT_GT(cv::countNonZero(Render(scene, rig, 0, options, frame)), 0) << frame;
  }
}

TEST(Renderer, VignettingDarkensTheCorners) {
  const Scene scene = StreetScene();
  const Rig rig = PinholeRig();
  RenderOptions options;
  const cv::Mat plain = Render(scene, rig, 0, options);
  options.effects.vignetting = true;
  const cv::Mat vignetted = Render(scene, rig, 0, options);
  auto ratio = [&](int x, int y) {
    const cv::Rect box(x - 4, y - 4, 9, 9);
    return cv::mean(vignetted(box))[0] / cv::mean(plain(box))[0];
  };
  // Corner: 200 px off centre at f = 250, 38.7 degrees: cos^4 = 0.37.
  const double centre = ratio(160, 120);
  const double corner = ratio(4, 4);
  std::printf("vignetting ratio: centre %.3f, corner %.3f\n", centre, corner);
  EXPECT_NEAR(centre, 1.0, 0.02);
  EXPECT_NEAR(corner, std::pow(std::cos(std::atan(std::hypot(155.5, 115.5) / 250.0)), 4), 0.03);
  EXPECT_DOUBLE_EQ(VignettingFalloff(0.0), 1.0);
  EXPECT_DOUBLE_EQ(VignettingFalloff(1.2), 0.3);
  EXPECT_DOUBLE_EQ(VignettingFalloff(2.5), 0.3);
}

TEST(Renderer, ExposureGainIsSmoothBoundedAndPerCamera) {
  RenderEffects effects;
  EXPECT_EQ(ExposureGain(effects, 3, 0, 123456789), 1.0);
  effects.exposure_changes = true;
  double lowest = 2.0, highest = 0.0, largest_step = 0.0, camera_difference = 0.0;
  const int64_t period_ns = 100'000'000;  // 10 Hz
  for (int frame = 0; frame < 600; ++frame) {
    const double gain = ExposureGain(effects, 3, 0, frame * period_ns);
    lowest = std::min(lowest, gain);
    highest = std::max(highest, gain);
    largest_step =
        std::max(largest_step, std::abs(gain - ExposureGain(effects, 3, 0, (frame + 1) * period_ns)));
    camera_difference =
        std::max(camera_difference, std::abs(gain - ExposureGain(effects, 3, 1, frame * period_ns)));
  }
  std::printf("exposure gain over 60 s: [%.3f, %.3f], largest step per frame %.4f\n", lowest, highest,
              largest_step);
  EXPECT_GE(lowest, 0.7);
  EXPECT_LE(highest, 1.3);
  EXPECT_LT(lowest, 0.85);
  EXPECT_GT(highest, 1.15);
  EXPECT_LT(largest_step, 0.045);
  EXPECT_GT(camera_difference, 0.1);

  // The image follows the gain (a dark scene region so nothing clips).
  const Scene scene = StreetScene();
  const Rig rig = PinholeRig();
  RenderOptions options;
  const cv::Mat reference = Render(scene, rig, 0, options);
  options.effects.exposure_changes = true;
  for (int64_t t_ns : {int64_t{0}, int64_t{1'700'000'000}, int64_t{4'100'000'000}}) {
    const cv::Mat image = Render(scene, rig, 0, options, 0, t_ns);
    const cv::Rect bottom(0, 160, 320, 80);  // asphalt
    const double measured = cv::mean(image(bottom))[0] / cv::mean(reference(bottom))[0];
    EXPECT_NEAR(measured, ExposureGain(options.effects, 0, 0, t_ns), 0.02) << t_ns;
  }
}

// Mean squared Laplacian: the high-frequency energy of an image.
double HighFrequencyEnergy(const cv::Mat& image) {
  cv::Mat laplacian;
  cv::Laplacian(image, laplacian, CV_32F);
  return cv::mean(laplacian.mul(laplacian))[0];
}

TEST(Renderer, MotionBlurSmoothsAMovingCamera) {
  const Scene scene = StreetScene();
  const Rig rig = PinholeRig();
  RenderOptions options;
  options.effects.exposure_time_s = 0.02;
  // The rig drives at 20 m/s: 0.4 m during the exposure, ~12 px at the
  // facade 8 m away seen by the side camera.
  auto pose = [](int64_t t_ns) { return RigAt(20.0 * t_ns * 1e-9); };
  const cv::Mat sharp = RenderImage(scene, rig, 1, pose, 0, 0, options);
  options.effects.motion_blur_samples = 8;
  const cv::Mat blurred = RenderImage(scene, rig, 1, pose, 0, 0, options);
  const double sharp_energy = HighFrequencyEnergy(sharp);
  const double blurred_energy = HighFrequencyEnergy(blurred);
  std::printf("high-frequency energy: sharp %.1f, motion-blurred %.1f\n", sharp_energy, blurred_energy);
  EXPECT_LT(blurred_energy, 0.5 * sharp_energy);
  // A static camera is not blurred by the motion-blur samples (static scene part).
  const cv::Mat still_sharp = Render(scene, rig, 1, RenderOptions());
  const cv::Mat still_blurred = Render(scene, rig, 1, options);
  EXPECT_LT(MeanAbsDifference(still_sharp, still_blurred), 0.6);

  const std::vector<int64_t> instants = ExposureInstants(1'000'000'000, options.effects);
  ASSERT_EQ(instants.size(), 8u);
  EXPECT_EQ(instants.front(), 1'000'000'000 - 8'750'000);
  EXPECT_EQ(instants.back(), 1'000'000'000 + 8'750'000);
  options.effects.motion_blur_samples = 1;
  EXPECT_EQ(ExposureInstants(5, options.effects), std::vector<int64_t>{5});
}

// A brick facade 80 m away, much finer than the pixels (a brick course
// ~0.2 px): moved sideways by a quarter pixel, the image changes by about a
// quarter of its pixel-to-pixel differences (no flicker); moved by exactly
// one pixel, it is the same image shifted by one pixel.
TEST(Renderer, FineTexturesDoNotFlicker) {
  Scene scene;
  scene.AddQuad(MakeQuad({80, 150, -60}, {0, -300, 0}, {0, 0, 150}, Material::kFacadeBrick, 11));
  scene.Build();
  const Rig rig = PinholeRig();
  const double metres_per_px = 80.0 / 250.0;
  RenderOptions options;
  auto render_at = [&](double shift_px) {
    return RenderImage(
        scene, rig, 0, [&](int64_t) { return RigAt(0.0, -shift_px * metres_per_px); }, 0, 0, options);
  };
  const cv::Mat base = render_at(0.0);
  const cv::Mat quarter = render_at(0.25);
  const cv::Mat one = render_at(1.0);
  const cv::Rect inner(8, 8, 300, 220);
  const cv::Rect inner_shifted = inner + cv::Point(1, 0);
  // The camera moves to -y = +x_cam: the scene moves left by one pixel.
  const double neighbour = MeanAbsDifference(base(inner_shifted), base(inner));
  const double quarter_change = MeanAbsDifference(quarter(inner), base(inner));
  const double one_px_mismatch = MeanAbsDifference(one(inner), base(inner_shifted));
  std::printf(
      "facade 80 m: neighbouring pixels differ by %.2f, quarter-pixel move changes %.2f, one-pixel move "
      "vs shifted image %.3f grey levels\n",
      neighbour, quarter_change, one_px_mismatch);
  EXPECT_GT(neighbour, 1.0);  // the facade has structure (windows)
  EXPECT_LT(quarter_change, 0.45 * neighbour);
  EXPECT_LT(one_px_mismatch, 0.15 * neighbour);
}

TEST(Renderer, FisheyeOutsideItsImageCircleIsBlack) {
  Camera camera = ScaledCamera(test::Kitti360Image02(), 0.25);
  camera.cam_from_rig = ForwardCamFromRig();
  Rig rig;
  rig.cameras = {camera};
  const Scene scene = StreetScene();
  const cv::Mat image = Render(scene, rig, 0, RenderOptions());
  EXPECT_EQ(image.at<uint8_t>(0, 0), 0);
  EXPECT_EQ(image.at<uint8_t>(349, 349), 0);
  EXPECT_GT(image.at<uint8_t>(175, 175), 20);
}

TEST(Renderer, OptionsCheckNamesTheBadField) {
  auto expect_rejected = [](const RenderOptions& options, const std::string& field) {
    try {
      options.Check();
      ADD_FAILURE() << "accepted bad " << field;
    } catch (const UsageError& error) {
      EXPECT_EQ(std::string(error.what()).rfind(field + ":", 0), 0u) << error.what();
    }
  };
  EXPECT_NO_THROW(RenderOptions().Check());
  RenderOptions o;
  o.samples_per_axis = 0;
  expect_rejected(o, "samples_per_axis");
  o = RenderOptions();
  o.samples_per_axis = 9;
  expect_rejected(o, "samples_per_axis");
  o = RenderOptions();
  o.max_distance_m = -1.0;
  expect_rejected(o, "max_distance_m");
  o = RenderOptions();
  o.threads = -2;
  expect_rejected(o, "threads");
  o = RenderOptions();
  o.effects.noise_sigma = -1.0;
  expect_rejected(o, "effects.noise_sigma");
  o = RenderOptions();
  o.effects.noise_sigma = std::nan("");
  expect_rejected(o, "effects.noise_sigma");
  o = RenderOptions();
  o.effects.motion_blur_samples = -1;
  expect_rejected(o, "effects.motion_blur_samples");
  o = RenderOptions();
  o.effects.exposure_time_s = 0.0;
  expect_rejected(o, "effects.exposure_time_s");
  o = RenderOptions();
  o.effects.blackout_camera = -3;
  expect_rejected(o, "effects.blackout_camera");
  o = RenderOptions();
  o.effects.blackout_num_frames = -1;
  expect_rejected(o, "effects.blackout_num_frames");
  EXPECT_THROW(RenderImageAtPoses(Scene(), PinholeRig(), 0, {Rigid3d()}, {0}, 0, o), UsageError);
}

}  // namespace
}  // namespace mcvo::synth
