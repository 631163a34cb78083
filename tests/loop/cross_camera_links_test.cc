// Cross-camera links across time on a hand-built straight drive: two
// right-looking cameras 3 m apart along the rig (no overlap at one time) see
// a wall; the rear camera sees 12 keyframes later what the front one saw.
// The odometry's motion is `scale` times too long, as on a straight road
// without overlap: each camera's landmarks are consistent with its own
// rays, not with the other camera's.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "camera/test_cameras.h"
#include "mcvo/dataset/overlap.h"
#include "mcvo/loop/cross_camera_links.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr int kKeyframes = 41;
constexpr double kStepM = 0.25;     // rig motion per keyframe, along z
constexpr double kHalfBaseM = 1.5;  // cameras at z = +-1.5 m in the rig
constexpr int64_t kRearIdOffset = 100000;

Rig SideRig() {
  Rig rig;
  // Looking right (rig +x): camera x = rig -z, y = rig y, z = rig x.
  Eigen::Matrix3d r;
  r << 0, 0, -1, 0, 1, 0, 1, 0, 0;
  for (double z : {kHalfBaseM, -kHalfBaseM}) {
    Camera camera =
        test::MakeCamera(z > 0 ? "front" : "rear", CameraModelId::kPinhole, {800, 800, 320, 240}, 640, 480);
    camera.cam_from_rig = Rigid3d(r, -(r * Eigen::Vector3d(0, 0, z)));
    rig.cameras.push_back(camera);
  }
  return rig;
}

struct Scenario {
  Rig rig = SideRig();
  std::vector<LinkKeyframe> keyframes;
  // Physical point index of each landmark id.
  std::map<int64_t, int> point_of;
};

// Wall points at x = 3 m; the front camera's landmark of point i has id i,
// the rear camera's kRearIdOffset + i, with the same descriptor (a few bits
// flipped). `distractors`: the rear camera also tracks, 3 px beside each of
// its landmarks, another one (id + kRearIdOffset) with an unrelated
// descriptor.
// `impostor`: the rear camera's tracks are of points 0.4 m nearer than the
// front camera's of the same descriptor (another point, seen in line with
// it from one place only).
Scenario MakeScenario(double scale, bool distractors = false, bool impostor = false) {
  Scenario s;
  std::mt19937 rng(7);
  std::vector<Eigen::Vector3d> points;
  std::vector<cv::Mat> descriptors;
  for (double z = -2.0; z <= 16.0; z += 0.45) {
    for (double y = -1.0; y <= 1.0; y += 0.5) {
      points.emplace_back(3.0, y, z);
      cv::Mat d(1, 32, CV_8U);
      for (int b = 0; b < 32; ++b) d.at<uchar>(0, b) = static_cast<uchar>(rng() & 0xff);
      descriptors.push_back(d);
    }
  }
  for (int k = 0; k < kKeyframes; ++k) {
    const Eigen::Vector3d position(0.0, 0.0, kStepM * k);
    LinkKeyframe kf;
    kf.frame_index = 3 * k;
    kf.world_from_rig = Rigid3d(Eigen::Quaterniond::Identity(), scale * position);  // the odometry's
    for (int c = 0; c < 2; ++c) {
      const Camera& camera = s.rig.cameras[static_cast<size_t>(c)];
      const Rigid3d cam_from_world =
          camera.cam_from_rig * Rigid3d(Eigen::Quaterniond::Identity(), position).Inverse();
      const Eigen::Vector3d offset = camera.cam_from_rig.Inverse().translation;
      for (size_t i = 0; i < points.size(); ++i) {
        const Eigen::Vector3d point =
            impostor && c == 1 ? points[i] - Eigen::Vector3d(0.4, 0.0, 0.0) : points[i];
        const std::optional<Eigen::Vector2d> pixel = camera.Project(cam_from_world * point);
        if (!pixel || !camera.IsInImage(*pixel) || pixel->x() < 20 || pixel->x() > 620) continue;
        const int64_t id = (c == 0 ? 0 : kRearIdOffset) + static_cast<int64_t>(i);
        kf.camera.push_back(c);
        kf.pixel.push_back(*pixel);
        kf.landmark_id.push_back(id);
        // Where the odometry triangulates it: consistent with this camera's rays.
        kf.point_in_world.push_back(scale * point + (1.0 - scale) * offset);
        cv::Mat d = descriptors[i].clone();
        if (c == 1) d.at<uchar>(0, static_cast<int>(i % 32)) ^= 0x07;
        kf.descriptors.push_back(d);
        s.point_of[id] = static_cast<int>(i);
        if (distractors && c == 1) {
          kf.camera.push_back(c);
          kf.pixel.push_back(*pixel + Eigen::Vector2d(3.0, 0.0));
          kf.landmark_id.push_back(id + kRearIdOffset);
          kf.point_in_world.push_back(kf.point_in_world.back());
          cv::Mat other(1, 32, CV_8U);
          for (int b = 0; b < 32; ++b) other.at<uchar>(0, b) = static_cast<uchar>(rng() & 0xff);
          kf.descriptors.push_back(other);
        }
      }
    }
    s.keyframes.push_back(kf);
  }
  return s;
}

CrossCameraLinkOptions Options() {
  CrossCameraLinkOptions o;
  o.window_keyframes = 20;
  return o;
}

TEST(CrossCameraLinksTest, LinksTheRearCamerasLandmarksToTheFrontOnesAndMeasuresTheScale) {
  for (double scale : {1.0, 1.04, 0.97}) {
    SCOPED_TRACE(scale);
    const Scenario s = MakeScenario(scale);
    const std::vector<CrossCameraLink> links = FindCrossCameraLinks(s.rig, s.keyframes, Options(), 2);
    ASSERT_GE(links.size(), 50u);
    std::set<std::pair<int64_t, int64_t>> pairs;
    for (const CrossCameraLink& link : links) {
      EXPECT_EQ(s.point_of.at(link.landmark_id), s.point_of.at(link.source_landmark_id));
      EXPECT_NE(link.camera, link.source_camera);
      EXPECT_TRUE(pairs.insert(std::minmax(link.landmark_id, link.source_landmark_id)).second)
          << "reported twice";
      // The motion that makes the two cameras' rays meet: 1 / scale.
      EXPECT_NEAR(link.scale, 1.0 / scale, 0.011);
      EXPECT_LE(link.view_angle_deg, Options().max_view_angle_deg);
      const LinkKeyframe& kf = s.keyframes[static_cast<size_t>(link.keyframe)];
      EXPECT_EQ(link.frame_index, kf.frame_index);
    }
  }
}

TEST(CrossCameraLinksTest, AScaleErrorBeyondTheBoundFindsNothing) {
  const Scenario s = MakeScenario(1.12);
  EXPECT_TRUE(FindCrossCameraLinks(s.rig, s.keyframes, Options(), 1).empty());
  CrossCameraLinkOptions wide = Options();
  wide.max_scale_error = 0.15;
  EXPECT_FALSE(FindCrossCameraLinks(s.rig, s.keyframes, wide, 1).empty());
}

TEST(CrossCameraLinksTest, UnlikeDescriptorsAreNotLinked) {
  Scenario s = MakeScenario(1.02);
  for (LinkKeyframe& kf : s.keyframes) {
    for (size_t r = 0; r < kf.camera.size(); ++r) {
      if (kf.camera[r] == 1) kf.descriptors.row(static_cast<int>(r)).setTo(0);
    }
    for (size_t r = 0; r < kf.camera.size(); ++r) {
      if (kf.camera[r] == 0) kf.descriptors.row(static_cast<int>(r)).setTo(255);
    }
  }
  EXPECT_TRUE(FindCrossCameraLinks(s.rig, s.keyframes, Options(), 2).empty());
}

TEST(CrossCameraLinksTest, TracksWhoseRaysDoNotMeetAreNotLinked) {
  // In line from one keyframe, with the same descriptor: only the rays of
  // the whole tracks tell the two points apart.
  const Scenario s = MakeScenario(1.0, false, true);
  const std::vector<CrossCameraLink> links = FindCrossCameraLinks(s.rig, s.keyframes, Options(), 2);
  EXPECT_TRUE(links.empty());
}

TEST(CrossCameraLinksTest, NeighboursWithOtherDescriptorsDoNotWin) {
  const Scenario plain = MakeScenario(1.03);
  const Scenario s = MakeScenario(1.03, true);
  const std::vector<CrossCameraLink> links = FindCrossCameraLinks(s.rig, s.keyframes, Options(), 2);
  const std::vector<CrossCameraLink> expected =
      FindCrossCameraLinks(plain.rig, plain.keyframes, Options(), 2);
  ASSERT_EQ(links.size(), expected.size());
  for (size_t i = 0; i < links.size(); ++i) {
    EXPECT_EQ(links[i].landmark_id, expected[i].landmark_id);
    EXPECT_EQ(links[i].source_landmark_id, expected[i].source_landmark_id);
  }
}

TEST(CrossCameraLinksTest, SameResultAtAnyThreadCountAndNoneWithoutAWindow) {
  const Scenario s = MakeScenario(1.04);
  const std::vector<CrossCameraLink> one = FindCrossCameraLinks(s.rig, s.keyframes, Options(), 1);
  const std::vector<CrossCameraLink> two = FindCrossCameraLinks(s.rig, s.keyframes, Options(), 2);
  ASSERT_EQ(one.size(), two.size());
  for (size_t i = 0; i < one.size(); ++i) {
    EXPECT_EQ(one[i].keyframe, two[i].keyframe);
    EXPECT_EQ(one[i].landmark_id, two[i].landmark_id);
    EXPECT_EQ(one[i].source_landmark_id, two[i].source_landmark_id);
    EXPECT_EQ(one[i].scale, two[i].scale);
  }
  CrossCameraLinkOptions off = Options();
  off.window_keyframes = 0;
  EXPECT_TRUE(FindCrossCameraLinks(s.rig, s.keyframes, off, 2).empty());
}

TEST(CrossCameraLinksTest, CameraPairsWhoseViewsOverlapCanBeLeftToTheFrontend) {
  const Scenario s = MakeScenario(1.03);
  const std::vector<std::pair<int, int>> overlapping = {{0, 1}};
  CrossCameraLinkOptions without = Options();
  without.overlapping_pairs = false;
  EXPECT_TRUE(FindCrossCameraLinks(s.rig, s.keyframes, without, 2, overlapping).empty());
  EXPECT_EQ(FindCrossCameraLinks(s.rig, s.keyframes, Options(), 2, overlapping).size(),
            FindCrossCameraLinks(s.rig, s.keyframes, Options(), 2).size());
}

TEST(CrossCameraLinksTest, PairsLookingTheSameWayCanBeLeftOut) {
  const Scenario s = MakeScenario(1.03);
  const Camera &front = s.rig.cameras[0], &rear = s.rig.cameras[1];
  const double mutual =
      std::min(ViewOverlap(front, rear, kViewOverlapDepthM), ViewOverlap(rear, front, kViewOverlapDepthM));
  ASSERT_GT(mutual, 0.2);  // 3 m apart, both looking right: much of one view at 10 m
  ASSERT_LT(mutual, 0.9);
  const size_t all = FindCrossCameraLinks(s.rig, s.keyframes, Options(), 2).size();
  ASSERT_GT(all, 0u);
  CrossCameraLinkOptions below = Options();
  below.max_pair_overlap = mutual - 0.05;
  EXPECT_TRUE(FindCrossCameraLinks(s.rig, s.keyframes, below, 2).empty());
  CrossCameraLinkOptions above = Options();
  above.max_pair_overlap = mutual + 0.05;
  EXPECT_EQ(FindCrossCameraLinks(s.rig, s.keyframes, above, 2).size(), all);
}

TEST(CrossCameraLinksTest, OptionsAreChecked) {
  CrossCameraLinkOptions o = Options();
  o.max_scale_error = -0.1;
  EXPECT_THROW(o.Check(), InputError);
  o = Options();
  o.radius_px = 0.0;
  EXPECT_THROW(o.Check(), InputError);
  o = Options();
  o.min_parallax_deg = -1.0;
  EXPECT_THROW(o.Check(), InputError);
  o = Options();
  o.window_keyframes = -1;
  EXPECT_THROW(o.Check(), InputError);
  o = Options();
  o.max_pair_overlap = 1.5;
  EXPECT_THROW(o.Check(), InputError);
}

}  // namespace
}  // namespace mcvo
