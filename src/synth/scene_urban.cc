// Urban scene: a grid of streets lined with continuous building facades.
//
// Layout (metres, world z up): street centre lines x = xs[0..kLinesX-1],
// y = ys[0..kLinesY-1]; every street is 17 m between facades (11 m road,
// 3 m sidewalks). Each block between street lines is lined with building
// boxes along its four edges (street walls with a few alleys), and an outer
// ring of buildings closes the views down every street. The route is a closed
// loop on the interior streets, driven in the right lane (2 m right of the
// centre line), with left and right turns at intersections.
#include <array>
#include <cmath>
#include <map>
#include <tuple>

#include "mcvo/synth/scene.h"
#include "scene_build_util.h"

namespace mcvo::synth {
namespace {

using Eigen::Vector2d;
using internal::SceneRng;

constexpr int kLinesX = 6;
constexpr int kLinesY = 5;
constexpr double kRoadHalf = 5.5;    // road: +-5.5 m from the centre line
constexpr double kStreetHalf = 8.5;  // facades: +-8.5 m (3 m sidewalks)
constexpr double kLane = 2.0;        // right-lane offset of the route
constexpr double kOuterDepth = 16.0;
constexpr double kMarkingZ = 0.005;
constexpr double kPi = 3.14159265358979323846;

// A facade design reused by several buildings: realistic repetition
// (identical facades in different streets) for loop-closure tests.
struct Design {
  Material material;
  uint32_t seed;
  double width, height;
};

// Which street segments the route drives along: key (vertical?, line, index
// of the segment along the line) -> unit direction of travel.
using SegmentKey = std::tuple<int, int, int>;

class UrbanBuilder {
 public:
  explicit UrbanBuilder(uint64_t seed) : rng_(seed) {}

  SceneWithRoute Build() {
    xs_.push_back(0.0);
    for (int i = 1; i < kLinesX; ++i) xs_.push_back(xs_.back() + rng_.Uniform(72.0, 96.0) + 2 * kStreetHalf);
    ys_.push_back(0.0);
    for (int j = 1; j < kLinesY; ++j) ys_.push_back(ys_.back() + rng_.Uniform(72.0, 96.0) + 2 * kStreetHalf);
    for (int k = 0; k < 4; ++k) {
      designs_.push_back({rng_.Bernoulli(0.5) ? Material::kFacadeBrick : Material::kFacadePlaster,
                          rng_.Seed32(), rng_.Uniform(10.0, 20.0), rng_.Uniform(10.0, 24.0)});
    }
    MakeRoute();
    AddBlocks();
    AddOuterRing();
    AddStreets();
    result_.name = "urban";
    result_.route_closed = true;
    result_.style = MotionStyle::kVehicle;
    result_.speed_mps = 10.0;
    result_.rig_height_m = 1.5;
    result_.scene.Build();
    return std::move(result_);
  }

 private:
  Scene& scene() { return result_.scene; }

  void AddBoxes(const std::vector<BoxSpec>& boxes) {
    for (const BoxSpec& b : boxes) scene().AddBox(b);
  }

  // Closed loop on the interior grid (grid indices), counter-clockwise with
  // a U-shaped detour: 6 left and 2 right turns.
  void MakeRoute() {
    const std::vector<std::array<int, 2>> grid = {{1, 1}, {2, 1}, {3, 1}, {4, 1}, {4, 2}, {4, 3},
                                                  {3, 3}, {3, 2}, {2, 2}, {2, 3}, {1, 3}, {1, 2}};
    const int n = static_cast<int>(grid.size());
    const auto centre = [&](int k) {
      const auto& g = grid[(k + n) % n];
      return Vector2d(xs_[g[0]], ys_[g[1]]);
    };
    const auto right = [](const Vector2d& d) { return Vector2d(d.y(), -d.x()); };
    for (int k = 0; k < n; ++k) {
      const Vector2d c = centre(k);
      const Vector2d dir_in = (c - centre(k - 1)).normalized(), dir_out = (centre(k + 1) - c).normalized();
      const Vector2d p = dir_in.dot(dir_out) > 0.5 ? Vector2d(c + kLane * right(dir_in))
                                                   : Vector2d(c + kLane * (right(dir_in) + right(dir_out)));
      result_.waypoints.emplace_back(p.x(), p.y(), 0.0);
      // Record the street segment to the next grid point.
      const auto& g0 = grid[k];
      const auto& g1 = grid[(k + 1) % n];
      if (g0[1] == g1[1]) {
        route_segments_[{0, g0[1], std::min(g0[0], g1[0])}] = dir_out;
      } else {
        route_segments_[{1, g0[0], std::min(g0[1], g1[1])}] = dir_out;
      }
    }
  }

  // Adds a quad parallel to a facade (from a to b along the facade line) whose
  // front faces `outward`.
  void AddFacadeQuad(const Vector2d& a, const Vector2d& b, const Vector2d& outward, double z0, double height,
                     Material material, uint32_t seed) {
    const Vector2d d = b - a;
    const bool a_first = d.y() * outward.x() - d.x() * outward.y() > 0.0;  // right of a->b is outward
    scene().AddQuad(internal::VerticalQuad(a_first ? a : b, a_first ? b : a, z0, height, material, seed));
  }

  // Fills the facade line start -> end with buildings extending `depth`
  // behind it (away from `outward`).
  void AddBuildingRow(const Vector2d& start, const Vector2d& end, const Vector2d& outward, double depth,
                      bool allow_alleys) {
    const Vector2d dir = (end - start).normalized();
    const double length = (end - start).norm();
    double pos = 0.0;
    while (length - pos > 3.0) {
      if (allow_alleys && pos > 0.0 && length - pos > 15.0 && rng_.Bernoulli(0.12))
        pos += rng_.Uniform(2.5, 5.0);
      Design d{rng_.Bernoulli(0.5) ? Material::kFacadeBrick : Material::kFacadePlaster, rng_.Seed32(),
               rng_.Uniform(8.0, 25.0), rng_.Uniform(8.0, 30.0)};
      if (rng_.Bernoulli(0.2)) d = designs_[rng_.UniformInt(0, static_cast<int>(designs_.size()) - 1)];
      double width = d.width;
      if (length - pos - width < 6.0) width = length - pos;
      const Vector2d f0 = start + pos * dir, f1 = f0 + width * dir;
      const Vector2d facade_centre = 0.5 * (f0 + f1);
      BoxSpec box;
      box.center = Eigen::Vector3d(facade_centre.x() - 0.5 * depth * outward.x(),
                                   facade_centre.y() - 0.5 * depth * outward.y(), 0.0);
      box.yaw_rad = std::atan2(outward.y(), outward.x());  // box +x face towards the street
      box.size = Eigen::Vector3d(depth, width, d.height);
      box.side_material = d.material;
      box.top_material = Material::kMetal;
      box.texture_seed = d.seed;
      scene().AddBox(box);
      // Ground floor: a shop front 5 cm in front of the facade, or posters.
      const Vector2d off = 0.05 * outward;
      if (width >= 5.0 && rng_.Bernoulli(0.45)) {
        AddFacadeQuad(f0 + 0.4 * dir + off, f1 - 0.4 * dir + off, outward, 0.0, rng_.Uniform(3.6, 4.4),
                      Material::kShopFront, rng_.Seed32());
      } else if (width >= 4.0 && rng_.Bernoulli(0.35)) {
        const double w = rng_.Uniform(1.2, 2.6);
        const double at = rng_.Uniform(0.5, width - w - 0.5);
        AddFacadeQuad(f0 + at * dir + 0.6 * off, f0 + (at + w) * dir + 0.6 * off, outward,
                      rng_.Uniform(0.4, 1.0), rng_.Uniform(1.6, 2.4), Material::kPoster, rng_.Seed32());
      }
      pos += width;
    }
  }

  void AddBlocks() {
    for (int i = 0; i + 1 < kLinesX; ++i) {
      for (int j = 0; j + 1 < kLinesY; ++j) {
        const double x0 = xs_[i] + kStreetHalf, x1 = xs_[i + 1] - kStreetHalf;
        const double y0 = ys_[j] + kStreetHalf, y1 = ys_[j + 1] - kStreetHalf;
        const double depth = std::min(rng_.Uniform(12.0, 20.0), 0.5 * std::min(x1 - x0, y1 - y0) - 4.0);
        AddBuildingRow({x0, y0}, {x1, y0}, {0, -1}, depth, true);
        AddBuildingRow({x1, y1}, {x0, y1}, {0, 1}, depth, true);
        AddBuildingRow({x0, y1 - depth}, {x0, y0 + depth}, {-1, 0}, depth, true);
        AddBuildingRow({x1, y0 + depth}, {x1, y1 - depth}, {1, 0}, depth, true);
        scene().AddQuad(internal::HorizontalQuad(x0, y0, x1, y1, 0.0, Material::kSidewalk, rng_.Seed32()));
      }
    }
  }

  void AddOuterRing() {
    const double x0 = xs_.front() - kStreetHalf, x1 = xs_.back() + kStreetHalf;
    const double y0 = ys_.front() - kStreetHalf, y1 = ys_.back() + kStreetHalf;
    const double d = kOuterDepth;
    AddBuildingRow({x0 - d, y0}, {x1 + d, y0}, {0, 1}, d, false);
    AddBuildingRow({x1 + d, y1}, {x0 - d, y1}, {0, -1}, d, false);
    AddBuildingRow({x0, y1}, {x0, y0}, {1, 0}, d, false);
    AddBuildingRow({x1, y0}, {x1, y1}, {-1, 0}, d, false);
  }

  // Road, sidewalks, markings and props of every street segment and intersection.
  void AddStreets() {
    for (int i = 0; i < kLinesX; ++i) {
      for (int j = 0; j < kLinesY; ++j) AddIntersection(i, j);
    }
    for (int j = 0; j < kLinesY; ++j) {
      for (int i = 0; i + 1 < kLinesX; ++i) AddSegment(0, j, i, {xs_[i], ys_[j]}, {xs_[i + 1], ys_[j]});
    }
    for (int i = 0; i < kLinesX; ++i) {
      for (int j = 0; j + 1 < kLinesY; ++j) AddSegment(1, i, j, {xs_[i], ys_[j]}, {xs_[i], ys_[j + 1]});
    }
  }

  void AddIntersection(int i, int j) {
    const double cx = xs_[i], cy = ys_[j], r = kRoadHalf, s = kStreetHalf;
    scene().AddQuad(
        internal::HorizontalQuad(cx - r, cy - r, cx + r, cy + r, 0.0, Material::kAsphalt, rng_.Seed32()));
    // Arms: asphalt where a street continues, sidewalk where the street ends (T junction).
    const auto arm_material = [](bool street) { return street ? Material::kAsphalt : Material::kSidewalk; };
    scene().AddQuad(internal::HorizontalQuad(cx + r, cy - r, cx + s, cy + r, 0.0,
                                             arm_material(i + 1 < kLinesX), rng_.Seed32()));
    scene().AddQuad(
        internal::HorizontalQuad(cx - s, cy - r, cx - r, cy + r, 0.0, arm_material(i > 0), rng_.Seed32()));
    scene().AddQuad(internal::HorizontalQuad(cx - r, cy + r, cx + r, cy + s, 0.0,
                                             arm_material(j + 1 < kLinesY), rng_.Seed32()));
    scene().AddQuad(
        internal::HorizontalQuad(cx - r, cy - s, cx + r, cy - r, 0.0, arm_material(j > 0), rng_.Seed32()));
    for (int sx : {-1, 1}) {
      for (int sy : {-1, 1}) {
        scene().AddQuad(
            internal::HorizontalQuad(std::min(cx + sx * r, cx + sx * s), std::min(cy + sy * r, cy + sy * s),
                                     std::max(cx + sx * r, cx + sx * s), std::max(cy + sy * r, cy + sy * s),
                                     0.0, Material::kSidewalk, rng_.Seed32()));
      }
    }
  }

  // Street segment between intersection centres a and b (axis aligned).
  void AddSegment(int vertical, int line, int index, const Vector2d& a, const Vector2d& b) {
    const Vector2d dir = (b - a).normalized();
    const Vector2d left(-dir.y(), dir.x());
    const Vector2d p0 = a + kStreetHalf * dir, p1 = b - kStreetHalf * dir;
    const double length = (p1 - p0).norm();
    // Road and sidewalks as strips along the segment (axis_u along the street).
    scene().AddQuad(internal::StripQuad(p0, p1, 2 * kRoadHalf, 0.0, Material::kAsphalt, rng_.Seed32()));
    const double sidewalk = kStreetHalf - kRoadHalf, mid = 0.5 * (kStreetHalf + kRoadHalf);
    for (double side : {-1.0, 1.0}) {
      scene().AddQuad(internal::StripQuad(p0 + side * mid * left, p1 + side * mid * left, sidewalk, 0.0,
                                          Material::kSidewalk, rng_.Seed32()));
    }
    // Markings, each its own quad 5 mm above the road: the centre line
    // (axis_u along the street) and a crosswalk at each end (axis_u across
    // the road, 3 m along the street).
    scene().AddQuad(internal::StripQuad(p0 + 4.5 * dir, p1 - 4.5 * dir, 0.15, kMarkingZ,
                                        Material::kRoadMarking, rng_.Seed32()));
    for (const Vector2d& c : {Vector2d(p0 + 2.0 * dir), Vector2d(p1 - 2.0 * dir)}) {
      scene().AddQuad(internal::StripQuad(c - (kRoadHalf - 0.5) * left, c + (kRoadHalf - 0.5) * left, 3.0,
                                          kMarkingZ, Material::kRoadMarking, rng_.Seed32()));
    }
    // Route segments: parking only on the left (the rig drives on the right).
    const auto route = route_segments_.find({vertical, line, index});
    const bool on_route = route != route_segments_.end();
    const double left_side = on_route ? (route->second.dot(dir) > 0 ? 1.0 : -1.0) : 0.0;
    // Poles and trees on the sidewalks, away from the intersections.
    for (double side : {-1.0, 1.0}) {
      for (double at = rng_.Uniform(4.0, 12.0); at < length - 4.0; at += rng_.Uniform(24.0, 34.0)) {
        BoxSpec pole;
        const Vector2d p = p0 + at * dir + side * (kRoadHalf + 0.5) * left;
        pole.center = Eigen::Vector3d(p.x(), p.y(), 0.0);
        pole.size = Eigen::Vector3d(0.16, 0.16, rng_.Uniform(4.5, 6.5));
        pole.texture_seed = rng_.Seed32();
        scene().AddBox(pole);
      }
      if (rng_.Bernoulli(0.4)) {
        for (double at = rng_.Uniform(6.0, 12.0); at < length - 6.0; at += rng_.Uniform(11.0, 17.0)) {
          AddBoxes(internal::TreeBoxes(p0 + at * dir + side * 7.2 * left, rng_.Uniform(2.0, 2.6),
                                       rng_.Uniform(5.0, 8.0), &rng_));
        }
      }
      // Parked cars 4.4 m from the centre line, in runs with gaps.
      if (on_route && side != left_side) continue;
      if (rng_.Bernoulli(on_route ? 0.7 : 0.5)) {
        for (double at = rng_.Uniform(7.0, 15.0); at < length - 7.0; at += rng_.Uniform(5.5, 12.0)) {
          if (rng_.Bernoulli(0.25)) continue;
          const double yaw = std::atan2(dir.y(), dir.x()) + (rng_.Bernoulli(0.5) ? kPi : 0.0);
          AddBoxes(internal::CarBoxes(p0 + at * dir + side * 4.4 * left, yaw, &rng_));
        }
      }
    }
    // Moving cars: on route segments in the opposite lane only, elsewhere in
    // either lane; they stay 25 m from the intersection centres.
    if (rng_.Bernoulli(on_route ? 0.35 : 0.12) && (b - a).norm() > 70.0) {
      const double side = on_route ? left_side : (rng_.Bernoulli(0.5) ? 1.0 : -1.0);
      // Right-hand traffic: in the lane left of `dir` cars drive against it.
      const Vector2d travel = side > 0 ? Vector2d(-dir) : dir;
      const Vector2d lane = side * kLane * left;
      MovingObject car;
      car.quads_in_object = internal::CarQuadsInObject(&rng_);
      const Vector2d s0 = (travel.dot(dir) > 0 ? a : b) + 25.0 * travel + lane;
      const Vector2d s1 = (travel.dot(dir) > 0 ? b : a) - 25.0 * travel + lane;
      car.start_in_world = Eigen::Vector3d(s0.x(), s0.y(), 0.0);
      car.end_in_world = Eigen::Vector3d(s1.x(), s1.y(), 0.0);
      car.yaw_rad = std::atan2(travel.y(), travel.x());
      car.speed_mps = rng_.Uniform(5.0, 9.0);
      scene().AddMovingObject(std::move(car));
    }
  }

  SceneRng rng_;
  SceneWithRoute result_;
  std::vector<double> xs_, ys_;
  std::vector<Design> designs_;
  std::map<SegmentKey, Vector2d> route_segments_;
};

}  // namespace

SceneWithRoute BuildUrbanScene(uint64_t seed) { return UrbanBuilder(seed).Build(); }

}  // namespace mcvo::synth
