// Internal helpers of the scene builders (src/synth/scene_*.cc): a portable
// seeded generator and constructors for the common quads and props.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "mcvo/synth/scene.h"
#include "mcvo/util/hash.h"

namespace mcvo::synth::internal {

// Portable seeded generator of the scene builders (util/hash.h).
using SceneRng = SplitMix64Rng;

// Vertical rectangle on the segment p0 -> p1 (ground-plane xy), from height
// z0 to z0 + height; axis_v up; the front face (normal axis_u x axis_v) is on
// the right of the direction p0 -> p1 seen from above.
Quad VerticalQuad(const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, double z0, double height,
                  Material material, uint32_t seed);
// Horizontal rectangle [x0, x1] x [y0, y1] at height z (x0 < x1, y0 < y1),
// normal up (down when facing_down, for ceilings).
Quad HorizontalQuad(double x0, double y0, double x1, double y1, double z, Material material, uint32_t seed,
                    bool facing_down = false);
// Horizontal strip of `width` centred on the segment a -> b at height z:
// axis_u along a -> b (the long side), axis_v to its left, normal up.
Quad StripQuad(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double width, double z, Material material,
               uint32_t seed);

// Distance in the ground plane from p to the route polyline.
double DistanceToRoute(const Eigen::Vector2d& p, const std::vector<Eigen::Vector3d>& waypoints, bool closed);
// Distance in the ground plane from the route polyline to the footprint
// (rotated rectangle) of a box.
double BoxDistanceToRoute(const BoxSpec& box, const std::vector<Eigen::Vector3d>& waypoints, bool closed);

// Props. Cars are ~4.4 x 1.8 x 1.5 m (body and cabin), facing +x in their own
// frame, bottom at z = 0; trees are a trunk and a foliage crown.
std::vector<BoxSpec> CarBoxes(const Eigen::Vector2d& center, double yaw_rad, SceneRng* rng);
std::vector<Quad> CarQuadsInObject(SceneRng* rng);
std::vector<BoxSpec> TreeBoxes(const Eigen::Vector2d& center, double crown_size, double height,
                               SceneRng* rng);

}  // namespace mcvo::synth::internal
