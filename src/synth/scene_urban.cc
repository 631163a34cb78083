// Urban scenes: a grid of streets lined with continuous building facades.
//
// Layout (metres, world z up): street centre lines x = xs[0..lines_x-1],
// y = ys[0..lines_y-1]; every street is 17 m between facades (11 m road,
// 3 m sidewalks). Each block between street lines is lined with building
// boxes along its four edges (street walls with a few alleys), and an outer
// ring of buildings closes the views down every street. The route runs on
// the streets through the intersections, driven in the right lane (2 m right
// of the centre line).
//
// One generator, three variants (UrbanVariant below):
//  * urban: 6 x 5 street lines, blocks 72-96 m, a closed 1.2 km loop with a
//    U-shaped detour (6 left and 2 right turns).
//  * urban_block: the same city on 4 x 4 lines with blocks of 56-72 m; the
//    route is one lap counter-clockwise around the central block (4 left
//    turns, about 290-360 m), meant to be driven several times (loop closure).
//  * urban_repeated: 5 x 5 lines with blocks of 80-84 m whose buildings all
//    wear the same two facade designs (one plaster, one brick, alternating,
//    fixed widths and heights) and one shop-front design, no posters or trees;
//    the route is an open staircase (east, north, east, ...: 4 turns, rig
//    path about 470-490 m) that never comes back near an earlier place, so
//    every look-alike view is a false loop candidate.
// The urban variant draws exactly the random numbers it drew before the other
// two existed: its scene, route and images are unchanged for every seed.
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "mcvo/synth/scene.h"
#include "mcvo/util/error.h"
#include "scene_build_util.h"

namespace mcvo::synth {
namespace {

using Eigen::Vector2d;
using internal::SceneRng;

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

// What distinguishes the urban scenes. Grid coordinates (gx, gy) name the
// point (xs[gx], ys[gy]); a fractional coordinate lies on the street between
// two lines (the ends of an open route).
struct UrbanVariant {
  std::string name;
  int lines_x = 6;
  int lines_y = 5;
  double block_min_m = 72.0;  // block size between facades, drawn per street line
  double block_max_m = 96.0;
  // Route through intersection centres; consecutive points on one street
  // line and within one block (straight through an intersection: list it).
  std::vector<Vector2d> route;
  bool route_closed = true;
  double moving_car_on_route = 0.35;  // probability of a moving car per route segment
  bool trees = true;
  // Every building gets one of two fixed designs (alternating) on all four
  // sides, ground-floor shop fronts share one seed, no posters.
  bool repeated_facades = false;
};

UrbanVariant UrbanVariantNamed(const std::string& name) {
  UrbanVariant v;
  v.name = name;
  if (name == "urban") {
    // Closed loop, counter-clockwise with a U-shaped detour: 6 left and 2 right turns.
    v.route = {{1, 1}, {2, 1}, {3, 1}, {4, 1}, {4, 2}, {4, 3},
               {3, 3}, {3, 2}, {2, 2}, {2, 3}, {1, 3}, {1, 2}};
  } else if (name == "urban_block" || name == "urban_small_block") {
    // One block counter-clockwise: 4 left turns, lap 4 x (73-89 m + 4 m) less
    // the corner blends; the small block's lap 4 x (41-49 m + 4 m).
    v.lines_x = 4;
    v.lines_y = 4;
    v.block_min_m = name == "urban_block" ? 56.0 : 24.0;
    v.block_max_m = name == "urban_block" ? 72.0 : 32.0;
    v.route = {{1, 1}, {2, 1}, {2, 2}, {1, 2}};
    v.moving_car_on_route = 0.6;
  } else {
    MCVO_CHECK_MSG(name == "urban_repeated" || name == "urban_small_repeated", "unknown urban variant ",
                   name);
    // Open staircase from mid-block to mid-block: east, north, east, north,
    // east (5 blocks of 97-101 m, the small one's 53-57 m); x and y never
    // decrease, so points s metres apart along it are at least s / sqrt(2) apart.
    v.lines_x = 5;
    v.lines_y = 5;
    v.block_min_m = name == "urban_repeated" ? 80.0 : 36.0;
    v.block_max_m = name == "urban_repeated" ? 84.0 : 40.0;
    v.route = {{0.5, 1}, {1, 1}, {1, 2}, {2, 2}, {2, 3}, {3, 3}, {3.5, 3}};
    v.route_closed = false;
    v.trees = false;
    v.repeated_facades = true;
  }
  return v;
}

// The coordinate of grid coordinate g on the street lines `lines`.
double LineCoordinate(const std::vector<double>& lines, double g) {
  const int i = static_cast<int>(std::floor(g));
  const double f = g - i;
  MCVO_CHECK(i >= 0 && i < static_cast<int>(lines.size()) &&
             (f == 0.0 || i + 1 < static_cast<int>(lines.size())));
  return f == 0.0 ? lines[i] : lines[i] + f * (lines[i + 1] - lines[i]);
}

class UrbanBuilder {
 public:
  UrbanBuilder(UrbanVariant variant, uint64_t seed) : v_(std::move(variant)), rng_(seed) {}

  SceneWithRoute Build() {
    xs_.push_back(0.0);
    for (int i = 1; i < v_.lines_x; ++i)
      xs_.push_back(xs_.back() + rng_.Uniform(v_.block_min_m, v_.block_max_m) + 2 * kStreetHalf);
    ys_.push_back(0.0);
    for (int j = 1; j < v_.lines_y; ++j)
      ys_.push_back(ys_.back() + rng_.Uniform(v_.block_min_m, v_.block_max_m) + 2 * kStreetHalf);
    if (v_.repeated_facades) {
      // Two designs, regular and alike: a plaster one and a narrower brick one.
      const uint32_t plaster_seed = rng_.Seed32();
      const double plaster_width = rng_.Uniform(12.0, 15.0), plaster_height = rng_.Uniform(15.0, 19.0);
      const uint32_t brick_seed = rng_.Seed32();
      const double brick_width = rng_.Uniform(9.0, 11.0), brick_height = rng_.Uniform(11.0, 14.0);
      designs_.push_back({Material::kFacadePlaster, plaster_seed, plaster_width, plaster_height});
      designs_.push_back({Material::kFacadeBrick, brick_seed, brick_width, brick_height});
      shop_seed_ = rng_.Seed32();
    } else {
      for (int k = 0; k < 4; ++k) {
        designs_.push_back({rng_.Bernoulli(0.5) ? Material::kFacadeBrick : Material::kFacadePlaster,
                            rng_.Seed32(), rng_.Uniform(10.0, 20.0), rng_.Uniform(10.0, 24.0)});
      }
    }
    MakeRoute();
    AddBlocks();
    AddOuterRing();
    AddStreets();
    result_.name = v_.name;
    result_.route_closed = v_.route_closed;
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

  // Waypoints of the route in the right lane: on a straight through an
  // intersection 2 m right of the centre line, at a turn on the corner of the
  // two lanes, at the ends of an open route 2 m right of the street's centre.
  void MakeRoute() {
    const std::vector<Vector2d>& grid = v_.route;
    const int n = static_cast<int>(grid.size());
    const bool closed = v_.route_closed;
    MCVO_CHECK(n >= (closed ? 3 : 2));
    const auto centre = [&](int k) {
      const Vector2d& g = grid[(k + n) % n];
      return Vector2d(LineCoordinate(xs_, g.x()), LineCoordinate(ys_, g.y()));
    };
    const auto right = [](const Vector2d& d) { return Vector2d(d.y(), -d.x()); };
    for (int k = 0; k < n; ++k) {
      const Vector2d c = centre(k);
      Vector2d p;
      if (!closed && k == 0) {
        p = c + kLane * right((centre(1) - c).normalized());
      } else if (!closed && k == n - 1) {
        p = c + kLane * right((c - centre(k - 1)).normalized());
      } else {
        const Vector2d dir_in = (c - centre(k - 1)).normalized(), dir_out = (centre(k + 1) - c).normalized();
        p = dir_in.dot(dir_out) > 0.5 ? Vector2d(c + kLane * right(dir_in))
                                      : Vector2d(c + kLane * (right(dir_in) + right(dir_out)));
      }
      result_.waypoints.emplace_back(p.x(), p.y(), 0.0);
      if (!closed && k == n - 1) break;
      // Record the street segment to the next grid point.
      const Vector2d dir_out = (centre(k + 1) - c).normalized();
      const Vector2d& g0 = grid[k];
      const Vector2d& g1 = grid[(k + 1) % n];
      const bool vertical = g0.x() == g1.x();
      MCVO_CHECK(vertical || g0.y() == g1.y());
      const double line = vertical ? g0.x() : g0.y();
      const double lo = vertical ? std::min(g0.y(), g1.y()) : std::min(g0.x(), g1.x());
      const double hi = vertical ? std::max(g0.y(), g1.y()) : std::max(g0.x(), g1.x());
      MCVO_CHECK(line == std::floor(line) && hi <= std::floor(lo) + 1.0);
      route_segments_[{vertical ? 1 : 0, static_cast<int>(line), static_cast<int>(std::floor(lo))}] = dir_out;
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
    if (v_.repeated_facades) {
      AddRepeatedRow(start, end, outward, depth);
      return;
    }
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
      scene().AddBox(BuildingBox(f0, f1, width, outward, depth, d));
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

  // The building behind the facade f0 -> f1 (`width` apart) in design d, `depth` deep.
  static BoxSpec BuildingBox(const Vector2d& f0, const Vector2d& f1, double width, const Vector2d& outward,
                             double depth, const Design& d) {
    const Vector2d facade_centre = 0.5 * (f0 + f1);
    BoxSpec box;
    box.center = Eigen::Vector3d(facade_centre.x() - 0.5 * depth * outward.x(),
                                 facade_centre.y() - 0.5 * depth * outward.y(), 0.0);
    box.yaw_rad = std::atan2(outward.y(), outward.x());  // box +x face towards the street
    box.size = Eigen::Vector3d(depth, width, d.height);
    box.side_material = d.material;
    box.top_material = Material::kMetal;
    box.texture_seed = d.seed;
    return box;
  }

  // urban_repeated: the row alternates the two designs from its start, each
  // at its own width (the last building takes what is left), every side of a
  // building in its design's texture (the same seed on all four sides, not
  // BoxFaceSeed's per-face seeds), and every plaster building has the one
  // shop front design on its ground floor. No alleys, no posters.
  void AddRepeatedRow(const Vector2d& start, const Vector2d& end, const Vector2d& outward, double depth) {
    const Vector2d dir = (end - start).normalized();
    const double length = (end - start).norm();
    double pos = 0.0;
    for (size_t k = 0; length - pos > 3.0; ++k) {
      const Design& d = designs_[k % designs_.size()];
      double width = d.width;
      if (length - pos - width < 6.0) width = length - pos;
      const Vector2d f0 = start + pos * dir, f1 = f0 + width * dir;
      std::vector<Quad> faces = MakeBoxQuads(BuildingBox(f0, f1, width, outward, depth, d));
      for (size_t face = 0; face < faces.size(); ++face) {
        if (faces[face].material == d.material) faces[face].texture_seed = d.seed;
        scene().AddQuad(faces[face]);
      }
      if (d.material == Material::kFacadePlaster && width >= 5.0) {
        const Vector2d off = 0.05 * outward;
        AddFacadeQuad(f0 + 0.4 * dir + off, f1 - 0.4 * dir + off, outward, 0.0, 4.0, Material::kShopFront,
                      shop_seed_);
      }
      pos += width;
    }
  }

  void AddBlocks() {
    for (int i = 0; i + 1 < v_.lines_x; ++i) {
      for (int j = 0; j + 1 < v_.lines_y; ++j) {
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
    for (int i = 0; i < v_.lines_x; ++i) {
      for (int j = 0; j < v_.lines_y; ++j) AddIntersection(i, j);
    }
    for (int j = 0; j < v_.lines_y; ++j) {
      for (int i = 0; i + 1 < v_.lines_x; ++i) AddSegment(0, j, i, {xs_[i], ys_[j]}, {xs_[i + 1], ys_[j]});
    }
    for (int i = 0; i < v_.lines_x; ++i) {
      for (int j = 0; j + 1 < v_.lines_y; ++j) AddSegment(1, i, j, {xs_[i], ys_[j]}, {xs_[i], ys_[j + 1]});
    }
  }

  void AddIntersection(int i, int j) {
    const double cx = xs_[i], cy = ys_[j], r = kRoadHalf, s = kStreetHalf;
    scene().AddQuad(
        internal::HorizontalQuad(cx - r, cy - r, cx + r, cy + r, 0.0, Material::kAsphalt, rng_.Seed32()));
    // Arms: asphalt where a street continues, sidewalk where the street ends (T junction).
    const auto arm_material = [](bool street) { return street ? Material::kAsphalt : Material::kSidewalk; };
    scene().AddQuad(internal::HorizontalQuad(cx + r, cy - r, cx + s, cy + r, 0.0,
                                             arm_material(i + 1 < v_.lines_x), rng_.Seed32()));
    scene().AddQuad(
        internal::HorizontalQuad(cx - s, cy - r, cx - r, cy + r, 0.0, arm_material(i > 0), rng_.Seed32()));
    scene().AddQuad(internal::HorizontalQuad(cx - r, cy + r, cx + r, cy + s, 0.0,
                                             arm_material(j + 1 < v_.lines_y), rng_.Seed32()));
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
      if (v_.trees && rng_.Bernoulli(0.4)) {
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
    if (rng_.Bernoulli(on_route ? v_.moving_car_on_route : 0.12) && (b - a).norm() > 70.0) {
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

  const UrbanVariant v_;
  SceneRng rng_;
  SceneWithRoute result_;
  std::vector<double> xs_, ys_;
  std::vector<Design> designs_;
  uint32_t shop_seed_ = 0;  // urban_repeated: the one shop-front design
  std::map<SegmentKey, Vector2d> route_segments_;
};

}  // namespace

SceneWithRoute BuildUrbanScene(uint64_t seed) {
  return UrbanBuilder(UrbanVariantNamed("urban"), seed).Build();
}
SceneWithRoute BuildUrbanBlockScene(uint64_t seed) {
  return UrbanBuilder(UrbanVariantNamed("urban_block"), seed).Build();
}
SceneWithRoute BuildUrbanSmallBlockScene(uint64_t seed) {
  return UrbanBuilder(UrbanVariantNamed("urban_small_block"), seed).Build();
}
SceneWithRoute BuildUrbanSmallRepeatedScene(uint64_t seed) {
  return UrbanBuilder(UrbanVariantNamed("urban_small_repeated"), seed).Build();
}
SceneWithRoute BuildUrbanRepeatedScene(uint64_t seed) {
  return UrbanBuilder(UrbanVariantNamed("urban_repeated"), seed).Build();
}

}  // namespace mcvo::synth
