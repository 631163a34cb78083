// Cross-camera matches on rendered sequences: quantity and accuracy against
// the ray-cast ground truth, pair selection by view overlap, rejection of
// content that does not correspond, determinism, the track file round trip.
#include "mcvo/frontend/cross_camera.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "mcvo/dataset/dataset.h"
#include "mcvo/frontend/camera_tracker.h"
#include "mcvo/frontend/detector.h"
#include "mcvo/frontend/multi_camera_tracker.h"
#include "mcvo/frontend/track_file.h"
#include "mcvo/synth/renderer.h"
#include "mcvo/synth/scene.h"
#include "mcvo/synth/synthesize.h"
#include "mcvo/synth/trajectory.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr int64_t kFramePeriodNs = 100000000;  // 10 Hz
constexpr double kPi = 3.14159265358979323846;

// A few frames of a preset rig in the urban scene, images scaled by `scale`,
// with the valid-pixel masks and the ground truth to score matches.
struct RigSequence {
  Rig rig;
  std::vector<cv::Mat> masks;
  std::vector<std::vector<cv::Mat>> frames;  // [frame][camera]
  synth::SceneWithRoute world;
  std::unique_ptr<synth::SmoothTrajectory> trajectory;
  std::vector<int64_t> times;  // t_ns of each frame
};

std::unique_ptr<RigSequence> Render(const std::string& preset, double scale, int num_frames,
                                    int64_t t0_ns = 0, const std::string& scene = "urban") {
  auto s = std::make_unique<RigSequence>();
  s->rig = synth::PresetRig(preset);
  for (Camera& camera : s->rig.cameras) {
    camera.mask_path.clear();
    camera = ScaledCamera(camera, scale);
    s->masks.push_back(ValidPixelMask(camera));
  }
  s->world = synth::BuildScene(scene, 0);
  s->trajectory = std::make_unique<synth::SmoothTrajectory>(
      synth::TrajectorySpec{s->world.waypoints, s->world.route_closed, s->world.style, s->world.speed_mps,
                            2.5, s->world.rig_height_m, 0});
  synth::RenderOptions render;
  render.samples_per_axis = 1;
  for (int frame = 0; frame < num_frames; ++frame) {
    const int64_t t = t0_ns + frame * kFramePeriodNs;
    std::vector<cv::Mat> images;
    for (int c = 0; c < s->rig.NumCameras(); ++c) {
      images.push_back(synth::RenderImage(
          s->world.scene, s->rig, c, [&](int64_t time) { return s->trajectory->WorldFromRig(time); }, t,
          frame, render));
    }
    s->frames.push_back(std::move(images));
    s->times.push_back(t);
  }
  return s;
}

// Stereo pair (KITTI-360 image_00 / image_01, 0.54 m baseline) at half
// resolution (704 x 188), 4 frames.
const RigSequence& Stereo() {
  static const std::unique_ptr<RigSequence> sequence = Render("stereo", 0.5, 4);
  return *sequence;
}

// KITTI-360 image_00 + both MEI fisheyes at half resolution, 2 frames:
// pinhole-fisheye pairs (images of different sizes and geometry) and the
// fisheye rims.
const RigSequence& ThreeCam() {
  static const std::unique_ptr<RigSequence> sequence = Render("kitti360-3cam", 0.5, 2);
  return *sequence;
}

// Every frame matched through the warps (the tests of steps 1-6).
FrontendOptions EveryFrame() {
  FrontendOptions options;
  options.cross_camera.rematch_every = 1;
  return options;
}

std::vector<MultiCameraFrame> TrackAll(const RigSequence& seq, int threads,
                                       const FrontendOptions& options = EveryFrame()) {
  MultiCameraTracker tracker(seq.rig, seq.masks, options, threads);
  std::vector<MultiCameraFrame> out;
  for (size_t f = 0; f < seq.frames.size(); ++f)
    out.push_back(tracker.Track(static_cast<int>(f), seq.times[f], seq.frames[f]));
  return out;
}

// Ground truth of a match: the scene point on the ray of camera a's feature
// pixel, projected into camera b; nullopt when b does not see it (occluded or
// outside b's image).
std::optional<Eigen::Vector2d> TruePixelInB(const RigSequence& seq, int64_t t_ns, int a, int b,
                                            const Eigen::Vector2f& pixel_a) {
  const Camera& cam_a = seq.rig.cameras[static_cast<size_t>(a)];
  const Camera& cam_b = seq.rig.cameras[static_cast<size_t>(b)];
  const Rigid3d world_from_rig = seq.trajectory->WorldFromRig(t_ns);
  const Rigid3d world_from_a = world_from_rig * cam_a.cam_from_rig.Inverse();
  const Rigid3d world_from_b = world_from_rig * cam_b.cam_from_rig.Inverse();
  const std::optional<Eigen::Vector3d> bearing = cam_a.Unproject(pixel_a.cast<double>());
  if (!bearing) return std::nullopt;
  const std::optional<synth::Hit> hit = seq.world.scene.Intersect(
      world_from_a.translation, world_from_a.rotation * bearing->normalized(), t_ns);
  if (!hit) return std::nullopt;
  const Eigen::Vector3d point_in_b = world_from_b.Inverse() * hit->point;
  const std::optional<Eigen::Vector2d> pixel = cam_b.Project(point_in_b);
  if (!pixel || !cam_b.IsInImage(*pixel)) return std::nullopt;
  const Eigen::Vector3d to_point = hit->point - world_from_b.translation;
  const std::optional<synth::Hit> seen_from_b =
      seq.world.scene.Intersect(world_from_b.translation, to_point.normalized(), t_ns);
  if (!seen_from_b || seen_from_b->distance < to_point.norm() - 0.05) return std::nullopt;  // occluded
  return pixel;
}

void PrintPairStats(const MultiCameraFrame& frame) {
  for (const CrossCameraPairStats& s : frame.cross_pair_stats) {
    std::cout << "frame " << frame.frame_index << " pair " << s.camera_a << "-" << s.camera_b << ": features "
              << s.features << " outside " << s.outside_view << " lost_lk " << s.lost_lk << " fb "
              << s.lost_forward_backward << " epipolar " << s.lost_epipolar << " triangulation "
              << s.lost_triangulation << " over_limit " << s.over_limit << " matches " << s.matches << " ("
              << s.seconds * 1e3 << " ms)\n";
  }
}

struct PairScore {
  int features = 0;  // camera a's features, over the frames
  int matches = 0;
  int scored = 0;  // matches with a ground truth
  double median_error_px = 0.0;
  int over_2px = 0;
};

// Scores the matches of pair (a, b) over all frames against the ground truth.
PairScore Score(const RigSequence& seq, const std::vector<MultiCameraFrame>& frames, int a, int b) {
  PairScore score;
  std::vector<double> errors;
  for (size_t f = 0; f < frames.size(); ++f) {
    const MultiCameraFrame& frame = frames[f];
    std::map<uint64_t, Eigen::Vector2f> pixels_a;
    for (const TrackedFeature& feature : frame.cameras[static_cast<size_t>(a)].features)
      pixels_a[feature.id] = feature.pixel;
    score.features += static_cast<int>(pixels_a.size());
    for (const CrossCameraMatch& m : frame.cross_matches) {
      if (m.camera_a != a || m.camera_b != b) continue;
      ++score.matches;
      EXPECT_EQ(pixels_a.count(m.id_a), 1u) << "match names an unknown feature " << m.id_a;
      const std::optional<Eigen::Vector2d> truth = TruePixelInB(seq, frame.t_ns, a, b, pixels_a[m.id_a]);
      if (!truth) continue;
      const double error = (m.pixel_b.cast<double>() - *truth).norm();
      errors.push_back(error);
      if (error > 2.0) ++score.over_2px;
    }
  }
  score.scored = static_cast<int>(errors.size());
  if (!errors.empty()) {
    std::nth_element(errors.begin(), errors.begin() + static_cast<long>(errors.size() / 2), errors.end());
    score.median_error_px = errors[errors.size() / 2];
  }
  std::cout << "pair " << a << "-" << b << ": " << score.matches << " matches of " << score.features
            << " features, " << score.scored << " with ground truth, median error " << score.median_error_px
            << " px, " << score.over_2px << " over 2 px\n";
  return score;
}

TEST(CrossCameraTest, StereoMatchesAreManyAndAccurate) {
  const RigSequence& seq = Stereo();
  const std::vector<MultiCameraFrame> frames = TrackAll(seq, 2);
  for (const MultiCameraFrame& frame : frames) {
    ASSERT_EQ(frame.cross_pair_stats.size(), 1u);
    const CrossCameraPairStats& s = frame.cross_pair_stats[0];
    EXPECT_EQ(s.camera_a, 0);
    EXPECT_EQ(s.camera_b, 1);
    EXPECT_EQ(s.features, static_cast<int>(frame.cameras[0].features.size()));
    EXPECT_EQ(s.features, s.outside_view + s.lost_lk + s.lost_forward_backward + s.lost_epipolar +
                              s.lost_triangulation + s.over_limit + s.matches);
    EXPECT_EQ(s.matches, static_cast<int>(frame.cross_matches.size()));
    EXPECT_EQ(CountCrossCameraMatches(frame, 0), s.matches);
    EXPECT_EQ(CountCrossCameraMatches(frame, 1), 0);
    std::cout << "frame " << frame.frame_index << ": features " << s.features << " outside " << s.outside_view
              << " lost_lk " << s.lost_lk << " fb " << s.lost_forward_backward << " epipolar "
              << s.lost_epipolar << " triangulation " << s.lost_triangulation << " matches " << s.matches
              << " (" << s.seconds * 1e3 << " ms)\n";
    for (size_t i = 1; i < frame.cross_matches.size(); ++i) {
      EXPECT_LT(frame.cross_matches[i - 1].id_a, frame.cross_matches[i].id_a);
    }
  }
  const PairScore score = Score(seq, frames, 0, 1);
  EXPECT_GT(score.matches, score.features / 2);
  EXPECT_GT(score.scored, score.matches * 8 / 10);
  EXPECT_LT(score.median_error_px, 0.5);
  EXPECT_LE(score.over_2px, score.scored / 50);
}

TEST(CrossCameraTest, PinholeAndFisheyePairs) {
  const RigSequence& seq = ThreeCam();
  const std::vector<MultiCameraFrame> frames = TrackAll(seq, 2);
  for (const MultiCameraFrame& frame : frames) PrintPairStats(frame);
  ASSERT_EQ(frames.back().cross_pair_stats.size(), 3u);  // all pairs overlap (fisheye rims included)
  // Pinhole - fisheye: half of the pinhole's view is in each fisheye.
  for (const int b : {1, 2}) {
    const PairScore score = Score(seq, frames, 0, b);
    EXPECT_GT(score.matches, score.features / 5) << "0-" << b;
    EXPECT_LT(score.median_error_px, 0.5) << "0-" << b;
    EXPECT_LE(score.over_2px, score.scored / 20) << "0-" << b;
  }
  // The fisheyes share only their rims (strong, opposite distortion).
  const PairScore rims = Score(seq, frames, 1, 2);
  EXPECT_GT(rims.matches, 5);
  EXPECT_LT(rims.median_error_px, 1.0);
  EXPECT_LE(rims.over_2px, std::max(1, rims.scored / 5));
}

// Indoors most points are 1-5 m away, far from the first warp's 20 m: the
// warped patch is then distorted against a's (scale, shear at the fisheye
// rims), and LK ends off the point or fails. The second warp at
// near_distance_m (4 m) matches those points through a patch warped about
// right.
TEST(CrossCameraTest, NearWarpMatchesNearPoints) {
  static const std::unique_ptr<RigSequence> indoor =
      Render("kitti360-3cam", 0.5, 2, 20 * 1000000000LL, "indoor");
  const RigSequence& seq = *indoor;
  FrontendOptions far_only;
  far_only.cross_camera.near_distance_m = 0.0;
  const std::vector<MultiCameraFrame> without = TrackAll(seq, 2, far_only);
  const std::vector<MultiCameraFrame> with = TrackAll(seq, 2);
  for (const MultiCameraFrame& frame : with) PrintPairStats(frame);
  int matches_without = 0, matches_with = 0;
  for (const auto& [a, b] : std::vector<std::pair<int, int>>{{0, 1}, {0, 2}, {1, 2}}) {
    const PairScore before = Score(seq, without, a, b);
    const PairScore after = Score(seq, with, a, b);
    matches_without += before.matches;
    matches_with += after.matches;
    EXPECT_GE(after.matches, before.matches) << a << "-" << b;
    if (after.scored >= 10) {
      EXPECT_LT(after.median_error_px, 0.6) << a << "-" << b;
      EXPECT_LE(after.over_2px, after.scored / 10) << a << "-" << b;
    }
  }
  EXPECT_GT(matches_with, matches_without + matches_without / 4);
}

TEST(CrossCameraTest, PairsAreChosenByViewOverlap) {
  // irregular5: cameras 0-1, 0-3, 2-3, 3-4 share nothing at 10 m.
  Rig rig = synth::PresetRig("irregular5");
  std::vector<cv::Mat> masks;
  for (Camera& camera : rig.cameras) {
    camera = ScaledCamera(camera, 0.25);
    masks.push_back(ValidPixelMask(camera));
  }
  CrossCameraOptions options;
  const std::vector<std::pair<int, int>> pairs = SelectCrossCameraPairs(rig, masks, options);
  for (const auto& none : std::vector<std::pair<int, int>>{{0, 1}, {0, 3}, {2, 3}, {3, 4}}) {
    EXPECT_EQ(std::count(pairs.begin(), pairs.end(), none), 0) << none.first << "-" << none.second;
  }
  EXPECT_EQ(std::count(pairs.begin(), pairs.end(), std::make_pair(0, 2)), 1);
  EXPECT_TRUE(std::is_sorted(pairs.begin(), pairs.end()));
  options.min_view_overlap = 0.0;  // pairs that share nothing are never matched
  const std::vector<std::pair<int, int>> any = SelectCrossCameraPairs(rig, masks, options);
  EXPECT_EQ(std::count(any.begin(), any.end(), std::make_pair(0, 1)), 0);
  EXPECT_GT(any.size(), pairs.size());
  options.enabled = false;
  EXPECT_TRUE(SelectCrossCameraPairs(rig, masks, options).empty());
}

// Camera b shows another place (3 s later on the route): whatever LK finds
// there must fail the checks.
TEST(CrossCameraTest, UnrelatedImagesGiveAlmostNoMatches) {
  const RigSequence& seq = Stereo();
  const std::unique_ptr<RigSequence> later = Render("stereo", 0.5, 1, 3000000000LL);
  FrontendOptions options;
  MultiCameraTracker tracker(seq.rig, seq.masks, options, 1);
  const MultiCameraFrame frame = tracker.Track(0, 0, {seq.frames[0][0], later->frames[0][1]});
  ASSERT_EQ(frame.cross_pair_stats.size(), 1u);
  const CrossCameraPairStats& s = frame.cross_pair_stats[0];
  std::cout << "unrelated: features " << s.features << " lost_lk " << s.lost_lk << " fb "
            << s.lost_forward_backward << " epipolar " << s.lost_epipolar << " triangulation "
            << s.lost_triangulation << " matches " << s.matches << "\n";
  EXPECT_GT(s.features, 50);
  EXPECT_LE(s.matches, s.features / 20);
}

TEST(CrossCameraTest, MissingImageGivesNoMatches) {
  const RigSequence& seq = Stereo();
  MultiCameraTracker tracker(seq.rig, seq.masks, FrontendOptions(), 2);
  for (int missing = 0; missing < 2; ++missing) {
    std::vector<cv::Mat> images = seq.frames[0];
    images[static_cast<size_t>(missing)] = cv::Mat();
    const MultiCameraFrame frame = tracker.Track(2 * missing, 0, images);
    ASSERT_EQ(frame.cross_pair_stats.size(), 1u);
    EXPECT_EQ(frame.cross_pair_stats[0].features, 0);
    EXPECT_TRUE(frame.cross_matches.empty());
    const MultiCameraFrame next = tracker.Track(2 * missing + 1, kFramePeriodNs, seq.frames[1]);
    EXPECT_GT(next.cross_matches.size(), next.cameras[0].features.size() / 2);
  }
}

TEST(CrossCameraTest, OptionChecksNameTheField) {
  const auto error = [](const std::function<void(CrossCameraOptions*)>& change) -> std::string {
    FrontendOptions options;
    change(&options.cross_camera);
    try {
      options.Check();
    } catch (const InputError& e) {
      return e.what();
    }
    return "(no error)";
  };
  EXPECT_EQ(error([](CrossCameraOptions*) {}), "(no error)");
  EXPECT_EQ(error([](CrossCameraOptions* o) { o->min_view_overlap = 1.5; }),
            "/frontend/cross_camera/min_view_overlap: must be in [0, 1], got 1.5");
  EXPECT_EQ(error([](CrossCameraOptions* o) { o->init_distance_m = 0.0; }),
            "/frontend/cross_camera/init_distance_m: must be > 0, got 0");
  EXPECT_EQ(error([](CrossCameraOptions* o) { o->near_distance_m = -1.0; }),
            "/frontend/cross_camera/near_distance_m: must be >= 0, got -1");
  EXPECT_EQ(error([](CrossCameraOptions* o) { o->normalise_sigma_px = -2.0; }),
            "/frontend/cross_camera/normalise_sigma_px: must be >= 0, got -2");
  EXPECT_EQ(error([](CrossCameraOptions* o) { o->epipolar_threshold_px = -1.0; }),
            "/frontend/cross_camera/epipolar_threshold_px: must be > 0, got -1");
  EXPECT_EQ(error([](CrossCameraOptions* o) { o->min_angle_deg = 91.0; }),
            "/frontend/cross_camera/min_angle_deg: must be in [0, 90], got 91");
  EXPECT_EQ(error([](CrossCameraOptions* o) { o->max_matches_per_pair = -1; }),
            "/frontend/cross_camera/max_matches_per_pair: must be >= 0, got -1");
  EXPECT_EQ(error([](CrossCameraOptions* o) { o->rematch_every = 0; }),
            "/frontend/cross_camera/rematch_every: must be >= 1, got 0");
}

TEST(CrossCameraTest, BearingChecks) {
  // b 0.5 m to the right of a (a's centre at x = -0.5 in b), same orientation.
  const Rigid3d b_from_a(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.5, 0.0, 0.0));
  const double sine = 1.0 / std::hypot(1.0, 460.0);
  const double min_angle = 0.25 * kPi / 180.0;
  const Eigen::Vector3d point_in_a(1.0, -0.5, 8.0);
  const Eigen::Vector3d point_in_b = b_from_a * point_in_a;
  EXPECT_EQ(
      CheckCrossCameraBearings(point_in_a.normalized(), point_in_b.normalized(), b_from_a, sine, min_angle),
      CrossCameraCheck::kOk);
  // 2 px (at focal 460) off the epipolar plane (y is across it here).
  const Eigen::Vector3d off =
      (point_in_b / point_in_b.z() + Eigen::Vector3d(0.0, 2.0 / 460.0, 0.0)).normalized();
  EXPECT_EQ(CheckCrossCameraBearings(point_in_a.normalized(), off, b_from_a, sine, min_angle),
            CrossCameraCheck::kEpipolar);
  // Along the epipolar line but the rays diverge (would meet behind the cameras).
  const Eigen::Vector3d diverging =
      (point_in_a / point_in_a.z() + Eigen::Vector3d(0.1, 0.0, 0.0)).normalized();
  EXPECT_EQ(CheckCrossCameraBearings(point_in_a.normalized(), diverging, b_from_a, sine, min_angle),
            CrossCameraCheck::kTriangulation);
  // A point 500 m away: rays 0.06 deg apart.
  const Eigen::Vector3d far_in_a(1.0, -0.5, 500.0);
  EXPECT_EQ(CheckCrossCameraBearings(far_in_a.normalized(), (b_from_a * far_in_a).normalized(), b_from_a,
                                     sine, min_angle),
            CrossCameraCheck::kTriangulation);
  EXPECT_EQ(CheckCrossCameraBearings(far_in_a.normalized(), (b_from_a * far_in_a).normalized(), b_from_a,
                                     sine, 0.0),
            CrossCameraCheck::kOk);
  // A ray along the baseline has no epipolar plane.
  EXPECT_EQ(CheckCrossCameraBearings(Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitX(), b_from_a, sine, 0.0),
            CrossCameraCheck::kTriangulation);
}

bool SameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

void ExpectSameMatches(const std::vector<MultiCameraFrame>& x, const std::vector<MultiCameraFrame>& y) {
  ASSERT_EQ(x.size(), y.size());
  for (size_t f = 0; f < x.size(); ++f) {
    ASSERT_EQ(x[f].cross_matches.size(), y[f].cross_matches.size()) << "frame " << f;
    for (size_t i = 0; i < x[f].cross_matches.size(); ++i) {
      const CrossCameraMatch& m = x[f].cross_matches[i];
      const CrossCameraMatch& n = y[f].cross_matches[i];
      EXPECT_EQ(m.camera_a, n.camera_a);
      EXPECT_EQ(m.camera_b, n.camera_b);
      EXPECT_EQ(m.id_a, n.id_a);
      EXPECT_TRUE(SameBits(m.pixel_b.x(), n.pixel_b.x()) && SameBits(m.pixel_b.y(), n.pixel_b.y()));
    }
    ASSERT_EQ(x[f].cross_pair_stats.size(), y[f].cross_pair_stats.size());
    for (size_t p = 0; p < x[f].cross_pair_stats.size(); ++p) {
      const CrossCameraPairStats& s = x[f].cross_pair_stats[p];
      const CrossCameraPairStats& t = y[f].cross_pair_stats[p];
      EXPECT_EQ(
          std::tie(s.camera_a, s.camera_b, s.features, s.outside_view, s.lost_lk, s.lost_forward_backward,
                   s.lost_epipolar, s.lost_triangulation, s.over_limit, s.matches),
          std::tie(t.camera_a, t.camera_b, t.features, t.outside_view, t.lost_lk, t.lost_forward_backward,
                   t.lost_epipolar, t.lost_triangulation, t.over_limit, t.matches));
    }
  }
}

TEST(CrossCameraTest, SameMatchesWithOneAndTwoThreads) {
  const std::vector<MultiCameraFrame> one = TrackAll(ThreeCam(), 1);
  const std::vector<MultiCameraFrame> two = TrackAll(ThreeCam(), 2);
  ExpectSameMatches(one, two);
  const std::vector<MultiCameraFrame> stereo_one = TrackAll(Stereo(), 1);
  const std::vector<MultiCameraFrame> stereo_two = TrackAll(Stereo(), 2);
  ExpectSameMatches(stereo_one, stereo_two);
  EXPECT_FALSE(stereo_one.back().cross_matches.empty());
}

// The bearing grid shared by a camera's pairs is Unproject's unit bearing at
// every pixel (NaN outside the model's domain: the MEI fisheye's corners),
// and a matcher built on it matches as one that computes its own.
TEST(CrossCameraTest, SharedBearingGridIsUnprojectAndChangesNoMatch) {
  const RigSequence& seq = ThreeCam();
  const Camera& fisheye = seq.rig.cameras[1];
  const std::vector<Eigen::Vector3d> grid = UnitBearingGrid(fisheye, 2);
  ASSERT_EQ(grid.size(), static_cast<size_t>(fisheye.width) * static_cast<size_t>(fisheye.height));
  int outside = 0;
  for (int y = 0; y < fisheye.height; y += 7) {
    for (int x = 0; x < fisheye.width; x += 5) {
      const Eigen::Vector3d& g = grid[static_cast<size_t>(y) * static_cast<size_t>(fisheye.width) + x];
      const std::optional<Eigen::Vector3d> bearing = fisheye.Unproject(Eigen::Vector2d(x, y));
      if (!bearing) {
        EXPECT_TRUE(std::isnan(g.x()) && std::isnan(g.y()) && std::isnan(g.z())) << x << "," << y;
        ++outside;
        continue;
      }
      EXPECT_EQ(g, bearing->normalized()) << x << "," << y;  // the same arithmetic: bit-equal
    }
  }
  EXPECT_GT(outside, 0);  // the grid covers a fisheye's invalid corners
  const FrontendOptions options = EveryFrame();
  const std::vector<Eigen::Vector3d> grid_a = UnitBearingGrid(seq.rig.cameras[0], 1);
  for (const int b : {1, 2}) {
    const CrossCameraMatcher own(0, b, seq.rig.cameras[0], seq.rig.cameras[static_cast<size_t>(b)],
                                 seq.masks[static_cast<size_t>(b)], options, 1);
    const CrossCameraMatcher shared(0, b, seq.rig.cameras[0], seq.rig.cameras[static_cast<size_t>(b)],
                                    seq.masks[static_cast<size_t>(b)], options, 2, &grid_a);
    CameraTracker tracker_a(seq.rig.cameras[0], seq.masks[0], options, CreateDetector(options));
    CameraTracker tracker_b(seq.rig.cameras[static_cast<size_t>(b)], seq.masks[static_cast<size_t>(b)],
                            options, CreateDetector(options));
    CameraFrameResult result_a = tracker_a.Track(seq.frames[0][0]);
    uint64_t next_id = 1;
    tracker_a.AssignNewIds(&next_id, &result_a);
    tracker_b.Track(seq.frames[0][static_cast<size_t>(b)]);
    CrossCameraPairStats stats_own, stats_shared;
    const std::vector<CrossCameraMatch> m_own =
        own.Match(result_a.features, tracker_a.Pyramid(), tracker_b.Pyramid(), &stats_own);
    const std::vector<CrossCameraMatch> m_shared =
        shared.Match(result_a.features, tracker_a.Pyramid(), tracker_b.Pyramid(), &stats_shared);
    ASSERT_GT(m_own.size(), 10u) << "0-" << b;
    ASSERT_EQ(m_own.size(), m_shared.size()) << "0-" << b;
    for (size_t k = 0; k < m_own.size(); ++k) {
      EXPECT_EQ(m_own[k].id_a, m_shared[k].id_a);
      EXPECT_EQ(m_own[k].pixel_b, m_shared[k].pixel_b);
    }
  }
}

TEST(CrossCameraTest, LimitKeepsTheLongestTracks) {
  FrontendOptions options = EveryFrame();
  options.cross_camera.max_matches_per_pair = 10;
  const std::vector<MultiCameraFrame> limited = TrackAll(Stereo(), 1, options);
  const std::vector<MultiCameraFrame> all = TrackAll(Stereo(), 1);
  const MultiCameraFrame& frame = limited.back();
  ASSERT_EQ(frame.cross_matches.size(), 10u);
  EXPECT_EQ(frame.cross_pair_stats[0].over_limit, static_cast<int>(all.back().cross_matches.size()) - 10);
  std::map<uint64_t, int> length;
  for (const TrackedFeature& f : frame.cameras[0].features) length[f.id] = f.track_length;
  int shortest_kept = 1 << 30;
  for (const CrossCameraMatch& m : frame.cross_matches)
    shortest_kept = std::min(shortest_kept, length[m.id_a]);
  for (const CrossCameraMatch& m : all.back().cross_matches) {
    const bool kept = std::any_of(frame.cross_matches.begin(), frame.cross_matches.end(),
                                  [&](const CrossCameraMatch& k) { return k.id_a == m.id_a; });
    if (!kept) {
      EXPECT_LE(length[m.id_a], shortest_kept);
    }
  }
  options.cross_camera.enabled = false;
  const std::vector<MultiCameraFrame> off = TrackAll(Stereo(), 1, options);
  EXPECT_TRUE(off.back().cross_matches.empty());
  EXPECT_TRUE(off.back().cross_pair_stats.empty());
}

// rematch_every 3 on the stereo pair: frame 0 and 3 matched through the
// warps, frames 1 and 2 follow the matches of the frame before in b's images.
TEST(CrossCameraTest, FollowedMatchesBetweenFullFramesStayAccurate) {
  const RigSequence& seq = Stereo();
  FrontendOptions options;
  options.detect_missing_fraction = 0.0;  // new features on every frame, to wait for frame 3
  FrontendOptions every_frame = options;
  every_frame.cross_camera.rematch_every = 1;
  options.cross_camera.rematch_every = 3;
  const std::vector<MultiCameraFrame> frames = TrackAll(seq, 2, options);
  const std::vector<MultiCameraFrame> every = TrackAll(seq, 2, every_frame);
  ASSERT_EQ(frames.size(), 4u);
  for (size_t f = 0; f < frames.size(); ++f) {
    const CrossCameraPairStats& s = frames[f].cross_pair_stats.at(0);
    EXPECT_EQ(s.features, s.outside_view + s.lost_lk + s.lost_forward_backward + s.lost_epipolar +
                              s.lost_triangulation + s.over_limit + s.matches);
    std::map<uint64_t, int> in_a;
    for (const TrackedFeature& feature : frames[f].cameras[0].features) in_a[feature.id] = 1;
    if (f == 0 || f == 3) {  // full frames: every feature of a searched, as without rematch_every
      EXPECT_EQ(s.features, static_cast<int>(frames[f].cameras[0].features.size())) << "frame " << f;
      continue;
    }
    // Followed: only a's features still tracked that were matched in the
    // frame before, and most of them survive.
    std::map<uint64_t, int> before;
    for (const CrossCameraMatch& m : frames[f - 1].cross_matches) before[m.id_a] = 1;
    int still_tracked = 0;
    for (const auto& [id, one] : before) still_tracked += in_a.count(id) ? one : 0;
    EXPECT_EQ(s.features, still_tracked) << "frame " << f;
    EXPECT_GE(s.matches, still_tracked * 9 / 10) << "frame " << f;
    for (const CrossCameraMatch& m : frames[f].cross_matches) EXPECT_EQ(before.count(m.id_a), 1u);
    for (size_t i = 1; i < frames[f].cross_matches.size(); ++i) {
      EXPECT_LT(frames[f].cross_matches[i - 1].id_a, frames[f].cross_matches[i].id_a);
    }
  }
  // Fewer matches (new features wait for frame 3), as accurate as matching every frame.
  const PairScore followed = Score(seq, frames, 0, 1);
  const PairScore full = Score(seq, every, 0, 1);
  EXPECT_LT(followed.matches, full.matches);
  EXPECT_GT(followed.matches, full.matches * 7 / 10);
  EXPECT_GT(followed.scored, followed.matches * 8 / 10);
  EXPECT_LT(followed.median_error_px, 0.5);
  EXPECT_LE(followed.over_2px, followed.scored / 50);
  // The same at one thread, bit for bit.
  ExpectSameMatches(TrackAll(seq, 1, options), frames);
}

// A frame after b's image was missing has nothing to follow from: it is
// matched in full; so is a frame where too few matches survive.
TEST(CrossCameraTest, FollowingFallsBackToFullMatching) {
  const RigSequence& seq = Stereo();
  FrontendOptions options;
  options.cross_camera.rematch_every = 4;
  MultiCameraTracker tracker(seq.rig, seq.masks, options, 2);
  const MultiCameraFrame first = tracker.Track(0, seq.times[0], seq.frames[0]);
  ASSERT_GT(first.cross_matches.size(), 20u);
  std::vector<cv::Mat> images = seq.frames[1];
  images[1] = cv::Mat();
  const MultiCameraFrame missing = tracker.Track(1, seq.times[1], images);
  EXPECT_TRUE(missing.cross_matches.empty());
  const MultiCameraFrame after = tracker.Track(2, seq.times[2], seq.frames[2]);
  EXPECT_EQ(after.cross_pair_stats.at(0).features, static_cast<int>(after.cameras[0].features.size()));
  EXPECT_GT(after.cross_matches.size(), after.cameras[0].features.size() / 2);

  // rematch_below_fraction 1: a frame between is kept only if every match survived.
  options.cross_camera.rematch_below_fraction = 1.0;
  const std::vector<MultiCameraFrame> strict = TrackAll(seq, 1, options);
  int last_full = static_cast<int>(strict[0].cross_matches.size());
  for (size_t f = 1; f < strict.size(); ++f) {
    const CrossCameraPairStats& s = strict[f].cross_pair_stats.at(0);
    if (s.features == static_cast<int>(strict[f].cameras[0].features.size())) {
      last_full = s.matches;
    } else {
      EXPECT_GE(s.matches, last_full) << "frame " << f;
    }
  }
}

TEST(CrossCameraTest, TrackFileRoundTrip) {
  const std::vector<MultiCameraFrame> frames = TrackAll(ThreeCam(), 2);
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) / "cross_camera_test.bin";
  TrackFileHeader header;
  for (const Camera& camera : ThreeCam().rig.cameras) header.camera_names.push_back(camera.name);
  header.detector = "shi_tomasi";
  {
    TrackFileWriter writer(path, header);
    for (const MultiCameraFrame& frame : frames) writer.Write(frame);
    writer.Commit();
  }
  TrackFileReader reader(path);
  EXPECT_EQ(reader.header().format_version, 3);
  std::vector<MultiCameraFrame> read;
  while (std::optional<MultiCameraFrame> frame = reader.Next()) read.push_back(std::move(*frame));
  ExpectSameMatches(frames, read);
  size_t matches = 0;
  for (const MultiCameraFrame& frame : read) matches += frame.cross_matches.size();
  EXPECT_GT(matches, 0u);
}

}  // namespace
}  // namespace mcvo
