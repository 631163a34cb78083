#include "mcvo/frontend/multi_camera_tracker.h"

#include <cmath>
#include <cstring>
#include <set>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "mcvo/dataset/dataset.h"
#include "mcvo/synth/renderer.h"
#include "mcvo/synth/scene.h"
#include "mcvo/synth/synthesize.h"
#include "mcvo/synth/trajectory.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr int64_t kFramePeriodNs = 100000000;  // 10 Hz

// Three frames of the KITTI-360 rig (2 pinhole + 2 MEI fisheye cameras) at
// quarter resolution in the urban scene, with the fisheyes' valid-pixel masks.
struct RigSequence {
  Rig rig;
  std::vector<cv::Mat> masks;
  std::vector<std::vector<cv::Mat>> frames;  // [frame][camera]
};

const RigSequence& Sequence() {
  static const RigSequence* sequence = [] {
    auto* s = new RigSequence;
    s->rig = synth::PresetRig("kitti360");
    for (Camera& camera : s->rig.cameras) {
      camera.mask_path.clear();
      camera = ScaledCamera(camera, 0.25);
      s->masks.push_back(ValidPixelMask(camera));
    }
    const synth::SceneWithRoute world = synth::BuildScene("urban", 0);
    const synth::SmoothTrajectory trajectory(
        {world.waypoints, world.route_closed, world.style, world.speed_mps, 2.5, world.rig_height_m, 0});
    const synth::RenderOptions render;
    for (int frame = 0; frame < 3; ++frame) {
      std::vector<cv::Mat> images;
      for (int c = 0; c < s->rig.NumCameras(); ++c) {
        images.push_back(synth::RenderImage(
            world.scene, s->rig, c, [&](int64_t t) { return trajectory.WorldFromRig(t); },
            frame * kFramePeriodNs, frame, render));
      }
      s->frames.push_back(std::move(images));
    }
    return s;
  }();
  return *sequence;
}

std::vector<MultiCameraFrame> TrackAll(int threads, const std::vector<std::vector<cv::Mat>>& frames,
                                       FrontendOptions options = {}) {
  const RigSequence& seq = Sequence();
  options.detector = DetectorType::kShiTomasi;
  MultiCameraTracker tracker(seq.rig, seq.masks, options, threads);
  std::vector<MultiCameraFrame> out;
  for (size_t f = 0; f < frames.size(); ++f) {
    out.push_back(tracker.Track(static_cast<int>(f), static_cast<int64_t>(f) * kFramePeriodNs, frames[f]));
  }
  return out;
}

bool SameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

void ExpectIdentical(const std::vector<MultiCameraFrame>& a, const std::vector<MultiCameraFrame>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t f = 0; f < a.size(); ++f) {
    ASSERT_EQ(a[f].cameras.size(), b[f].cameras.size());
    EXPECT_EQ(a[f].frame_index, b[f].frame_index);
    EXPECT_EQ(a[f].t_ns, b[f].t_ns);
    for (size_t c = 0; c < a[f].cameras.size(); ++c) {
      const CameraFrameResult& ra = a[f].cameras[c];
      const CameraFrameResult& rb = b[f].cameras[c];
      ASSERT_EQ(ra.features.size(), rb.features.size()) << "frame " << f << " camera " << c;
      for (size_t i = 0; i < ra.features.size(); ++i) {
        EXPECT_EQ(ra.features[i].id, rb.features[i].id);
        EXPECT_TRUE(SameBits(ra.features[i].pixel.x(), rb.features[i].pixel.x()));
        EXPECT_TRUE(SameBits(ra.features[i].pixel.y(), rb.features[i].pixel.y()));
        EXPECT_TRUE(SameBits(ra.features[i].score, rb.features[i].score));
        EXPECT_EQ(ra.features[i].track_length, rb.features[i].track_length);
      }
      EXPECT_EQ(ra.descriptors.rows, rb.descriptors.rows);
      if (!ra.descriptors.empty()) {
        EXPECT_EQ(cv::norm(ra.descriptors, rb.descriptors, cv::NORM_INF), 0.0);
      }
      const CameraFrameStats& sa = ra.stats;
      const CameraFrameStats& sb = rb.stats;
      EXPECT_EQ(sa.image_missing, sb.image_missing);
      EXPECT_EQ(sa.tracked, sb.tracked);
      EXPECT_EQ(sa.lost_lk, sb.lost_lk);
      EXPECT_EQ(sa.lost_forward_backward, sb.lost_forward_backward);
      EXPECT_EQ(sa.ransac_inliers, sb.ransac_inliers);
      EXPECT_EQ(sa.ransac_outliers, sb.ransac_outliers);
      EXPECT_EQ(sa.new_features, sb.new_features);
      EXPECT_EQ(sa.mean_track_length, sb.mean_track_length);
      EXPECT_EQ(sa.sfd, sb.sfd);
    }
    ASSERT_EQ(a[f].cross_matches.size(), b[f].cross_matches.size()) << "frame " << f;
    for (size_t i = 0; i < a[f].cross_matches.size(); ++i) {
      const CrossCameraMatch& ma = a[f].cross_matches[i];
      const CrossCameraMatch& mb = b[f].cross_matches[i];
      EXPECT_EQ(ma.camera_a, mb.camera_a);
      EXPECT_EQ(ma.camera_b, mb.camera_b);
      EXPECT_EQ(ma.id_a, mb.id_a);
      EXPECT_TRUE(SameBits(ma.pixel_b.x(), mb.pixel_b.x()));
      EXPECT_TRUE(SameBits(ma.pixel_b.y(), mb.pixel_b.y()));
    }
    ASSERT_EQ(a[f].cross_pair_stats.size(), b[f].cross_pair_stats.size());
    for (size_t p = 0; p < a[f].cross_pair_stats.size(); ++p) {
      EXPECT_EQ(a[f].cross_pair_stats[p].matches, b[f].cross_pair_stats[p].matches);
      EXPECT_EQ(a[f].cross_pair_stats[p].lost_forward_backward,
                b[f].cross_pair_stats[p].lost_forward_backward);
    }
  }
}

TEST(MultiCameraTrackerTest, SameResultWithOneAndTwoThreads) {
  const RigSequence& seq = Sequence();
  const std::vector<MultiCameraFrame> one = TrackAll(1, seq.frames);
  const std::vector<MultiCameraFrame> two = TrackAll(2, seq.frames);
  const std::vector<MultiCameraFrame> four = TrackAll(4, seq.frames);
  ExpectIdentical(one, two);
  ExpectIdentical(one, four);
  // OpenCV's internal parallel loops split work differently with one thread.
  const int opencv_threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const std::vector<MultiCameraFrame> serial_opencv = TrackAll(2, seq.frames);
  cv::setNumThreads(opencv_threads);
  ExpectIdentical(one, serial_opencv);
  int tracked = 0;
  for (const CameraFrameResult& r : one.back().cameras) tracked += r.stats.tracked;
  EXPECT_GT(tracked, 50);
  // The KITTI-360 rig: every pair of its 4 cameras overlaps (the fisheyes
  // see beyond 180 deg), and pairs are matched in parallel too.
  EXPECT_EQ(one.back().cross_pair_stats.size(), 6u);
  EXPECT_FALSE(one.back().cross_matches.empty());
}

TEST(MultiCameraTrackerTest, NewIdsAreUniqueAndIncreaseInCameraOrder) {
  const RigSequence& seq = Sequence();
  const std::vector<MultiCameraFrame> frames = TrackAll(2, seq.frames);
  std::set<uint64_t> seen;
  uint64_t last_new = 0;
  for (const MultiCameraFrame& frame : frames) {
    for (size_t c = 0; c < frame.cameras.size(); ++c) {
      const CameraFrameResult& r = frame.cameras[c];
      EXPECT_FALSE(r.features.empty()) << "camera " << c;
      for (const TrackedFeature& f : r.features) {
        EXPECT_NE(f.id, 0u);
        if (f.track_length == 1) {
          EXPECT_GT(f.id, last_new);  // new ids: consecutive, camera 0 first
          EXPECT_EQ(f.id, last_new + 1);
          last_new = f.id;
          EXPECT_TRUE(seen.insert(f.id).second) << "id " << f.id << " reused";
        } else {
          EXPECT_EQ(seen.count(f.id), 1u) << "tracked id " << f.id << " never created";
        }
      }
    }
  }
}

TEST(MultiCameraTrackerTest, PixelScaleFollowsTheCameraSize) {
  FrontendOptions options;  // pixel_scale_reference_px 250
  EXPECT_NEAR(PixelScaleForCamera(options, 180, 135), std::sqrt(180.0 * 135.0) / 250.0, 1e-12);
  EXPECT_NEAR(PixelScaleForCamera(options, 246, 184), 0.851, 1e-3);  // irregular5's smallest camera at 0.48
  EXPECT_EQ(PixelScaleForCamera(options, 307, 230), 1.0);
  EXPECT_EQ(PixelScaleForCamera(options, 1400, 1400), 1.0);
  EXPECT_EQ(PixelScaleForCamera(options, 0, 135), 1.0);
  options.pixel_scale_reference_px = 0.0;
  EXPECT_EQ(PixelScaleForCamera(options, 180, 135), 1.0);
}

TEST(MultiCameraTrackerTest, ScalePixelParametersRoundsAndKeepsFloors) {
  FrontendOptions options;
  const FrontendOptions same = ScalePixelParameters(options, 1.0);
  EXPECT_EQ(same.min_distance_px, 20);
  EXPECT_EQ(same.lk.window_px, 15);
  EXPECT_EQ(same.anchor.half_size_px, 10);
  EXPECT_EQ(same.clahe.tile_grid, 8);
  const FrontendOptions small = ScalePixelParameters(options, 0.62);  // a 180 x 135 camera
  EXPECT_EQ(small.min_distance_px, 12);
  EXPECT_EQ(small.lk.window_px, 9);  // 9.3: the nearest odd size
  EXPECT_EQ(small.anchor.half_size_px, 6);
  EXPECT_EQ(small.clahe.tile_grid, 5);
  EXPECT_EQ(ScalePixelParameters(options, 0.96).lk.window_px, 15);  // 14.4
  EXPECT_EQ(ScalePixelParameters(options, 0.9).lk.window_px, 13);   // 13.5
  const FrontendOptions tiny = ScalePixelParameters(options, 0.05);
  EXPECT_EQ(tiny.min_distance_px, 1);
  EXPECT_EQ(tiny.lk.window_px, 5);
  EXPECT_EQ(tiny.anchor.half_size_px, 3);
  EXPECT_EQ(tiny.clahe.tile_grid, 2);
  // A value the user set below a floor is never raised.
  options.lk.window_px = 3;
  options.min_distance_px = 0;
  EXPECT_EQ(ScalePixelParameters(options, 0.5).lk.window_px, 3);
  EXPECT_EQ(ScalePixelParameters(options, 0.5).min_distance_px, 0);
  // Nothing else moves.
  EXPECT_EQ(small.max_features_pinhole, options.max_features_pinhole);
  EXPECT_EQ(small.lk.pyramid_levels, options.lk.pyramid_levels);
  EXPECT_EQ(small.anchor.weight_sigma_px, options.anchor.weight_sigma_px);
}

// The quarter-resolution KITTI-360 rig: pinholes of 352 x 94 px (scaled by
// 0.73: min distance 15 px) and fisheyes of 350 x 350 px (not scaled).
TEST(MultiCameraTrackerTest, OnlySmallCamerasGetScaledParameters) {
  const RigSequence& seq = Sequence();
  FrontendOptions fixed;
  fixed.pixel_scale_reference_px = 0.0;
  const std::vector<MultiCameraFrame> scaled = TrackAll(2, seq.frames);
  const std::vector<MultiCameraFrame> unscaled = TrackAll(2, seq.frames, fixed);
  ASSERT_EQ(scaled.size(), unscaled.size());
  for (size_t f = 0; f < scaled.size(); ++f) {
    for (size_t c = 2; c < 4; ++c) {  // the fisheyes track as without scaling (ids aside: camera order)
      const std::vector<TrackedFeature>& a = scaled[f].cameras[c].features;
      const std::vector<TrackedFeature>& b = unscaled[f].cameras[c].features;
      ASSERT_EQ(a.size(), b.size()) << "frame " << f << " camera " << c;
      for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_TRUE(SameBits(a[i].pixel.x(), b[i].pixel.x()));
        EXPECT_TRUE(SameBits(a[i].pixel.y(), b[i].pixel.y()));
        EXPECT_EQ(a[i].track_length, b[i].track_length);
      }
    }
  }
  // The pinholes' budget of 100 does not fit at 20 px apart on 352 x 94 px;
  // at 15 px more of it does.
  for (size_t c = 0; c < 2; ++c) {
    EXPECT_GT(scaled[0].cameras[c].features.size(), unscaled[0].cameras[c].features.size()) << "camera " << c;
    EXPECT_LE(scaled[0].cameras[c].features.size(), 100u);
  }
}

TEST(MultiCameraTrackerTest, PinholeFeatureBudgetKeepsTheDensity) {
  FrontendOptions options;  // 100 features per 0.25 Mpx
  EXPECT_EQ(PinholeFeatureBudget(options, 704, 188), 100);    // the stereo preset at half resolution
  EXPECT_EQ(PinholeFeatureBudget(options, 602, 384), 100);    // the roof pair at 0.8, the suite's largest
  EXPECT_EQ(PinholeFeatureBudget(options, 625, 400), 100);    // exactly the reference
  EXPECT_EQ(PinholeFeatureBudget(options, 1241, 376), 187);   // KITTI odometry: 100 x 0.4666 / 0.25
  EXPECT_EQ(PinholeFeatureBudget(options, 752, 480), 144);    // EuRoC
  EXPECT_EQ(PinholeFeatureBudget(options, 1408, 376), 212);   // KITTI-360's pinholes
  EXPECT_EQ(PinholeFeatureBudget(options, 0, 480), 100);
  options.max_features_pinhole = 5000;
  EXPECT_EQ(PinholeFeatureBudget(options, 4000, 3000), 20000);  // capped at max_features_pinhole's own bound
  options.max_features_pinhole = 20000;
  EXPECT_EQ(PinholeFeatureBudget(options, 4000, 3000), 20000);
  options.max_features_pinhole = 100;
  options.max_features_pinhole_megapixels = 0.0;
  EXPECT_EQ(PinholeFeatureBudget(options, 1241, 376), 100);
  options.max_features_pinhole_megapixels = 0.15;
  EXPECT_EQ(PinholeFeatureBudget(options, 1241, 376), 311);
}

// The quarter-resolution KITTI-360 rig with a reference of 0.01 Mpx: the
// 352 x 94 pinholes (0.033 Mpx) get a budget of 331 and find more than 100
// features (6 px apart, so that they fit); the fisheyes keep
// max_features_fisheye and track as before.
TEST(MultiCameraTrackerTest, LargePinholeCamerasGetALargerBudget) {
  const RigSequence& seq = Sequence();
  FrontendOptions fixed;
  fixed.min_distance_px = 6;
  fixed.max_features_pinhole_megapixels = 0.0;
  FrontendOptions dense = fixed;
  dense.max_features_pinhole_megapixels = 0.01;
  ASSERT_EQ(PinholeFeatureBudget(dense, 352, 94), 331);
  const std::vector<MultiCameraFrame> a = TrackAll(2, seq.frames, fixed);
  const std::vector<MultiCameraFrame> b = TrackAll(2, seq.frames, dense);
  ASSERT_EQ(a.size(), b.size());
  for (size_t f = 0; f < a.size(); ++f) {
    for (size_t c = 0; c < 2; ++c) {
      EXPECT_LE(a[f].cameras[c].features.size(), 100u) << "frame " << f << " camera " << c;
      EXPECT_GT(b[f].cameras[c].features.size(), 100u) << "frame " << f << " camera " << c;
      EXPECT_LE(b[f].cameras[c].features.size(), 331u) << "frame " << f << " camera " << c;
    }
    for (size_t c = 2; c < 4; ++c) {
      const std::vector<TrackedFeature>& fa = a[f].cameras[c].features;
      const std::vector<TrackedFeature>& fb = b[f].cameras[c].features;
      ASSERT_EQ(fa.size(), fb.size()) << "frame " << f << " camera " << c;
      for (size_t i = 0; i < fa.size(); ++i) {
        EXPECT_TRUE(SameBits(fa[i].pixel.x(), fb[i].pixel.x()));
        EXPECT_TRUE(SameBits(fa[i].pixel.y(), fb[i].pixel.y()));
      }
    }
  }
}

TEST(MultiCameraTrackerTest, MissingCameraImage) {
  const RigSequence& seq = Sequence();
  std::vector<std::vector<cv::Mat>> frames = seq.frames;
  frames[1][2] = cv::Mat();
  const std::vector<MultiCameraFrame> out = TrackAll(2, frames);
  EXPECT_TRUE(out[1].cameras[2].stats.image_missing);
  EXPECT_TRUE(out[1].cameras[2].features.empty());
  EXPECT_EQ(out[2].cameras[2].stats.tracked, 0);
  EXPECT_GT(out[2].cameras[0].stats.tracked, 0);
  EXPECT_THROW(TrackAll(1, {std::vector<cv::Mat>(1)}), InputError);
}

}  // namespace
}  // namespace mcvo
