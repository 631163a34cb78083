// ViewOverlap on the preset rigs. The expected values are what the rigs'
// geometry gives (measured at 10 m and checked against the layout of the
// cameras), with margins that survive small calibration edits but not a
// broken transform direction or a swapped camera.
#include "mcvo/dataset/overlap.h"

#include <gtest/gtest.h>

#include "mcvo/dataset/dataset.h"
#include "mcvo/synth/synthesize.h"

namespace mcvo {
namespace {

constexpr double kDepth = kViewOverlapDepthM;

TEST(ViewOverlap, CameraWithItselfSeesEverything) {
  const Rig rig = synth::PresetRig("kitti360");
  EXPECT_DOUBLE_EQ(ViewOverlap(rig.cameras[0], rig.cameras[0], kDepth), 1.0);
  EXPECT_GT(ViewOverlap(rig.cameras[2], rig.cameras[2], kDepth), 0.99);  // fisheye round trip at the rim
}

TEST(ViewOverlap, Kitti360StereoPairOverlapsAlmostFully) {
  const Rig rig = synth::PresetRig("kitti360");
  // 0.6 m baseline, parallel axes: the pair differs by the strip the
  // baseline shifts out of view, about f * 0.6 / depth px of 1408 (~2.4 % at
  // 10 m at the grid's resolution: 0.969 measured).
  EXPECT_GT(ViewOverlap(rig.cameras[0], rig.cameras[1], kDepth), 0.95);
  EXPECT_GT(ViewOverlap(rig.cameras[1], rig.cameras[0], kDepth), 0.95);
  // The strip shrinks with distance.
  EXPECT_LT(ViewOverlap(rig.cameras[0], rig.cameras[1], 5.0),
            ViewOverlap(rig.cameras[0], rig.cameras[1], 20.0));
}

TEST(ViewOverlap, Kitti360FisheyesOverlapAheadAndBehind) {
  // The side fisheyes (MEI, image circle beyond 180 deg) look left and right;
  // each covers more than a hemisphere, so they share wedges ahead of and
  // behind the car (0.44 of either view at 10 m), and each sees the half of
  // the front camera's view on its side (0.54 / 0.56), while the narrow
  // front camera covers only ~7 % of a fisheye's view. So the "3cam" preset
  // is not free of overlap: the fisheyes see into image_00's view.
  for (const char* preset : {"kitti360", "kitti360-3cam"}) {
    const Rig rig = synth::PresetRig(preset);
    const Camera& front = rig.cameras[static_cast<size_t>(rig.FindCamera("image_00"))];
    const Camera& left = rig.cameras[static_cast<size_t>(rig.FindCamera("image_02"))];
    const Camera& right = rig.cameras[static_cast<size_t>(rig.FindCamera("image_03"))];
    EXPECT_NEAR(ViewOverlap(left, right, kDepth), 0.44, 0.08) << preset;
    EXPECT_NEAR(ViewOverlap(right, left, kDepth), 0.44, 0.08) << preset;
    EXPECT_NEAR(ViewOverlap(front, left, kDepth), 0.54, 0.08) << preset;
    EXPECT_NEAR(ViewOverlap(front, right, kDepth), 0.56, 0.08) << preset;
    EXPECT_NEAR(ViewOverlap(left, front, kDepth), 0.066, 0.03) << preset;
    EXPECT_NEAR(ViewOverlap(right, front, kDepth), 0.067, 0.03) << preset;
  }
}

TEST(ViewOverlap, MasksNarrowTheOverlap) {
  // KITTI-360 fisheyes limited to 95 deg from the axis (the reader's default
  // mask) share less of their views than the full model domain.
  const Rig rig = synth::PresetRig("kitti360");
  const Camera left = ScaledCamera(rig.cameras[2], 0.1);
  const Camera right = ScaledCamera(rig.cameras[3], 0.1);
  const double full = ViewOverlap(left, right, kDepth);
  const double masked =
      ViewOverlap(left, right, kDepth, ValidPixelMask(left, 95.0), ValidPixelMask(right, 95.0));
  EXPECT_LT(masked, full);
  EXPECT_GE(masked, 0.0);
}

TEST(ViewOverlap, Multicam6SideCamerasFacingAwayShareNothing) {
  const Rig rig = synth::PresetRig("multicam6");
  // cam4 and cam5 are the side cameras looking left and right: nothing in common.
  EXPECT_EQ(ViewOverlap(rig.cameras[4], rig.cameras[5], kDepth), 0.0);
  EXPECT_EQ(ViewOverlap(rig.cameras[5], rig.cameras[4], kDepth), 0.0);
  // The forward cameras overlap strongly.
  EXPECT_GT(ViewOverlap(rig.cameras[0], rig.cameras[1], kDepth), 0.8);
}

}  // namespace
}  // namespace mcvo
