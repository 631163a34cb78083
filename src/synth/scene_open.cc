// Open scene: grass terrain with a dirt road along a gentle closed curve,
// sparse nearby structure (boulders, trees, a hut) and distant hills
// (200-900 m away), so most of the view is far away (weak parallax).
#include <cmath>

#include "mcvo/synth/scene.h"
#include "scene_build_util.h"

namespace mcvo::synth {
namespace {

using Eigen::Vector2d;
using internal::SceneRng;

constexpr double kPi = 3.14159265358979323846;
constexpr int kNumWaypoints = 24;  // even: road strips alternate between two heights

class OpenBuilder {
 public:
  explicit OpenBuilder(uint64_t seed) : rng_(seed) {}

  SceneWithRoute Build() {
    result_.name = "open";
    result_.route_closed = true;
    result_.style = MotionStyle::kVehicle;
    result_.speed_mps = 10.0;
    result_.rig_height_m = 1.5;
    // Route: r(theta) = r0 (1 + a2 sin(2 theta + p2) + a3 sin(3 theta + p3)).
    const double r0 = rng_.Uniform(115.0, 135.0), p2 = rng_.Uniform(0, 2 * kPi),
                 p3 = rng_.Uniform(0, 2 * kPi);
    for (int k = 0; k < kNumWaypoints; ++k) {
      const double theta = 2 * kPi * k / kNumWaypoints;
      const double r = r0 * (1.0 + 0.12 * std::sin(2 * theta + p2) + 0.06 * std::sin(3 * theta + p3));
      result_.waypoints.emplace_back(r * std::cos(theta), r * std::sin(theta), 0.0);
    }
    AddGround();
    AddRoad();
    AddHills();
    AddNearStructure();
    result_.scene.Build();
    return std::move(result_);
  }

 private:
  Scene& scene() { return result_.scene; }

  // Grass tiled into 50 m quads near the route (so textures vary) and 300 m
  // quads out to 1350 m.
  void AddGround() {
    for (double x = -450.0; x < 449.0; x += 50.0) {
      for (double y = -450.0; y < 449.0; y += 50.0) {
        scene().AddQuad(
            internal::HorizontalQuad(x, y, x + 50.0, y + 50.0, 0.0, Material::kGrass, rng_.Seed32()));
      }
    }
    for (double x = -1350.0; x < 1349.0; x += 300.0) {
      for (double y = -1350.0; y < 1349.0; y += 300.0) {
        if (x >= -451.0 && x <= 151.0 && y >= -451.0 && y <= 151.0) continue;  // inner 900 m square
        scene().AddQuad(
            internal::HorizontalQuad(x, y, x + 300.0, y + 300.0, 0.0, Material::kGrass, rng_.Seed32()));
      }
    }
  }

  // A 5 m dirt road along the route: one strip per segment, lengthened to
  // cover the joints, alternating 4 / 8 mm above the grass (no z-fighting).
  void AddRoad() {
    const auto& w = result_.waypoints;
    for (int k = 0; k < kNumWaypoints; ++k) {
      const Vector2d a = w[k].head<2>(), b = w[(k + 1) % kNumWaypoints].head<2>();
      const Vector2d dir = (b - a).normalized();
      scene().AddQuad(internal::StripQuad(a - 1.5 * dir, b + 1.5 * dir, 5.0, k % 2 == 0 ? 0.004 : 0.008,
                                          Material::kAsphalt, rng_.Seed32()));
    }
  }

  // Hills: big rock boxes (a wide base and a narrower top) all around.
  void AddHills() {
    const int n = 16;
    for (int k = 0; k < n; ++k) {
      const double angle = 2 * kPi * (k + rng_.Uniform(-0.25, 0.25)) / n;
      const double distance = rng_.Uniform(480.0, 950.0);
      const double width = rng_.Uniform(0.45, 0.75) * distance * 2 * kPi / n;
      const double height = rng_.Uniform(25.0, 90.0);
      BoxSpec base;
      base.center = Eigen::Vector3d(distance * std::cos(angle), distance * std::sin(angle), 0.0);
      base.yaw_rad = angle;
      base.size = Eigen::Vector3d(rng_.Uniform(80.0, 200.0), width, height);
      base.side_material = Material::kRock;
      base.top_material = Material::kRock;
      base.texture_seed = rng_.Seed32();
      scene().AddBox(base);
      BoxSpec top = base;
      top.center.z() = height;
      top.yaw_rad = angle + rng_.Uniform(-0.2, 0.2);
      top.size = Eigen::Vector3d(0.6 * base.size.x(), rng_.Uniform(0.3, 0.6) * width,
                                 rng_.Uniform(0.3, 0.5) * height);
      top.texture_seed = rng_.Seed32();
      scene().AddBox(top);
    }
  }

  // A point `offset` to the side of a random route point.
  Vector2d NearRoute(double min_offset, double max_offset) {
    const auto& w = result_.waypoints;
    const int k = rng_.UniformInt(0, kNumWaypoints - 1);
    const Vector2d a = w[k].head<2>(), b = w[(k + 1) % kNumWaypoints].head<2>();
    const Vector2d dir = (b - a).normalized();
    const double side = rng_.Bernoulli(0.5) ? 1.0 : -1.0;
    return a + rng_.Uniform(0.0, 1.0) * (b - a) +
           side * rng_.Uniform(min_offset, max_offset) * Vector2d(-dir.y(), dir.x());
  }

  bool Clear(const BoxSpec& box, double clearance) {
    return internal::BoxDistanceToRoute(box, result_.waypoints, true) >= clearance;
  }

  void AddNearStructure() {
    for (int k = 0, placed = 0; k < 200 && placed < 18; ++k) {  // boulders
      BoxSpec rock;
      const Vector2d p = NearRoute(10.0, 70.0);
      rock.center = Eigen::Vector3d(p.x(), p.y(), 0.0);
      rock.yaw_rad = rng_.Uniform(0.0, kPi);
      rock.size = Eigen::Vector3d(rng_.Uniform(0.8, 3.0), rng_.Uniform(0.8, 3.0), rng_.Uniform(0.6, 2.0));
      rock.side_material = Material::kRock;
      rock.top_material = Material::kRock;
      rock.texture_seed = rng_.Seed32();
      if (!Clear(rock, 8.0)) continue;
      scene().AddBox(rock);
      ++placed;
    }
    for (int k = 0, placed = 0; k < 200 && placed < 14; ++k) {  // trees
      const Vector2d p = NearRoute(12.0, 90.0);
      const std::vector<BoxSpec> tree =
          internal::TreeBoxes(p, rng_.Uniform(3.0, 5.0), rng_.Uniform(6.0, 11.0), &rng_);
      if (!Clear(tree[1], 10.0)) continue;
      for (const BoxSpec& b : tree) scene().AddBox(b);
      ++placed;
    }
    for (int k = 0; k < 50; ++k) {  // a hut with an overhanging roof
      const Vector2d p = NearRoute(22.0, 30.0);
      BoxSpec hut;
      hut.center = Eigen::Vector3d(p.x(), p.y(), 0.0);
      hut.yaw_rad = rng_.Uniform(0.0, kPi);
      hut.size = Eigen::Vector3d(4.0, 3.0, 2.6);
      hut.side_material = Material::kWood;
      hut.top_material = Material::kWood;
      hut.texture_seed = rng_.Seed32();
      BoxSpec roof = hut;
      roof.center.z() = 2.6;
      roof.size = Eigen::Vector3d(4.8, 3.8, 0.25);
      roof.side_material = Material::kMetal;
      roof.top_material = Material::kMetal;
      roof.with_bottom = true;
      if (!Clear(roof, 15.0)) continue;
      scene().AddBox(hut);
      scene().AddBox(roof);
      break;
    }
    // A car driving up and down a straight track outside the loop.
    for (int k = 0; k < 50; ++k) {
      const double theta = rng_.Uniform(0.0, 2 * kPi);
      const Vector2d radial(std::cos(theta), std::sin(theta)), tangent(-radial.y(), radial.x());
      const Vector2d centre = rng_.Uniform(200.0, 230.0) * radial;
      const Vector2d a = centre - 70.0 * tangent, b = centre + 70.0 * tangent;
      if (internal::DistanceToRoute(a, result_.waypoints, true) < 25.0 ||
          internal::DistanceToRoute(b, result_.waypoints, true) < 25.0 ||
          internal::DistanceToRoute(centre, result_.waypoints, true) < 25.0) {
        continue;
      }
      scene().AddQuad(internal::StripQuad(a - 5.0 * tangent, b + 5.0 * tangent, 4.0, 0.004,
                                          Material::kAsphalt, rng_.Seed32()));
      MovingObject car;
      car.quads_in_object = internal::CarQuadsInObject(&rng_);
      car.start_in_world = Eigen::Vector3d(a.x(), a.y(), 0.0);
      car.end_in_world = Eigen::Vector3d(b.x(), b.y(), 0.0);
      car.yaw_rad = std::atan2(tangent.y(), tangent.x());
      car.speed_mps = rng_.Uniform(8.0, 12.0);
      scene().AddMovingObject(std::move(car));
      break;
    }
  }

  SceneRng rng_;
  SceneWithRoute result_;
};

}  // namespace

SceneWithRoute BuildOpenScene(uint64_t seed) { return OpenBuilder(seed).Build(); }

}  // namespace mcvo::synth
