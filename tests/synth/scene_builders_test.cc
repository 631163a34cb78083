#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "mcvo/synth/scene.h"
#include "mcvo/synth/trajectory.h"
#include "mcvo/util/error.h"

namespace mcvo::synth {
namespace {

using Eigen::Vector3d;

// Points along the route polyline every `step` metres, at ground level.
std::vector<Vector3d> RoutePoints(const SceneWithRoute& s, double step, int first = 0, int last = -1) {
  const int n = static_cast<int>(s.waypoints.size());
  if (last < 0) last = s.route_closed ? n : n - 1;
  std::vector<Vector3d> points;
  for (int i = first; i < last; ++i) {
    const Vector3d a = s.waypoints[i], b = s.waypoints[(i + 1) % n];
    const int steps = std::max(1, static_cast<int>((b - a).norm() / step));
    for (int k = 0; k < steps; ++k) points.push_back(a + (b - a) * (static_cast<double>(k) / steps));
  }
  return points;
}

Vector3d Horizontal(double angle) { return Vector3d(std::cos(angle), std::sin(angle), 0.0); }

bool IsFacade(Material m) {
  return m == Material::kFacadeBrick || m == Material::kFacadePlaster || m == Material::kShopFront ||
         m == Material::kPoster;
}

// Nearest horizontal hit around p (24 directions, several heights, three instants).
double NearestAround(const SceneWithRoute& s, const Vector3d& p) {
  double nearest = 1e9;
  for (double z : {0.3, 0.7, 1.0, s.rig_height_m, 2.0}) {
    for (int k = 0; k < 24; ++k) {
      for (int64_t t_ns : {int64_t{0}, int64_t{5'000'000'000}, int64_t{13'000'000'000}}) {
        const auto hit = s.scene.Intersect(p + Vector3d(0, 0, z), Horizontal(k * M_PI / 12), t_ns);
        if (hit) nearest = std::min(nearest, hit->distance);
      }
    }
  }
  return nearest;
}

TEST(SceneBuildersTest, EveryScenBuildsWithARoute) {
  EXPECT_EQ(SceneNames(),
            (std::vector<std::string>{"urban", "urban_block", "urban_small_block", "urban_repeated",
                                      "urban_small_repeated", "indoor", "open"}));
  for (const std::string& name : SceneNames()) {
    const SceneWithRoute s = BuildScene(name, 1);
    EXPECT_EQ(s.name, name);
    EXPECT_GE(s.waypoints.size(), 2u);
    EXPECT_GT(s.scene.quads().size(), 50u);
    for (const Vector3d& w : s.waypoints) EXPECT_EQ(w.z(), 0.0);
    // Build() was called: a ray down from the start hits the ground.
    const auto ground =
        s.scene.Intersect(s.waypoints[0] + Vector3d(0, 0, s.rig_height_m), -Vector3d::UnitZ(), 0);
    ASSERT_TRUE(ground.has_value()) << name;
    EXPECT_NEAR(ground->distance, s.rig_height_m, 0.01) << name;
    std::printf("%s\n", SceneSummary(s).c_str());
  }
}

TEST(SceneBuildersTest, UnknownSceneThrows) {
  try {
    BuildScene("forest", 0);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "unknown scene 'forest' (known: urban, urban_block, urban_small_block, urban_repeated, "
              "urban_small_repeated, indoor, open)");
  }
}

TEST(SceneBuildersTest, DeterministicForASeed) {
  for (const std::string& name : SceneNames()) {
    const SceneWithRoute a = BuildScene(name, 9), b = BuildScene(name, 9), c = BuildScene(name, 10);
    EXPECT_EQ(SceneSummary(a), SceneSummary(b));
    EXPECT_EQ(a.waypoints, b.waypoints);
    ASSERT_EQ(a.scene.quads().size(), b.scene.quads().size());
    for (size_t i = 0; i < a.scene.quads().size(); ++i) {
      EXPECT_EQ(a.scene.quads()[i].origin, b.scene.quads()[i].origin);
      EXPECT_EQ(a.scene.quads()[i].texture_seed, b.scene.quads()[i].texture_seed);
    }
    EXPECT_NE(a.waypoints, c.waypoints) << name;
  }
}

TEST(SceneBuildersTest, UrbanRouteIsAClosedLoopWithTurns) {
  for (uint64_t seed : {1, 2, 3}) {
    const SceneWithRoute s = BuildUrbanScene(seed);
    const RouteStats stats = ComputeRouteStats(s);
    EXPECT_TRUE(s.route_closed);
    EXPECT_EQ(s.style, MotionStyle::kVehicle);
    EXPECT_GE(stats.left_turns + stats.right_turns, 4);
    EXPECT_GE(stats.left_turns, 1);
    EXPECT_GE(stats.right_turns, 1);
    EXPECT_GE(stats.length_m, 800.0);
    EXPECT_LE(stats.length_m, 1500.0);
    // Straight stretches between waypoints are long enough to smooth turns.
    for (size_t i = 0; i < s.waypoints.size(); ++i) {
      EXPECT_GE((s.waypoints[(i + 1) % s.waypoints.size()] - s.waypoints[i]).norm(), 40.0);
    }
    EXPECT_GE(s.scene.moving_objects().size(), 1u);
  }
}

TEST(SceneBuildersTest, IndoorAndOpenRouteLengths) {
  const SceneWithRoute indoor = BuildIndoorScene(1);
  EXPECT_EQ(indoor.style, MotionStyle::kHandheld);
  EXPECT_TRUE(indoor.route_closed);
  EXPECT_GE(ComputeRouteStats(indoor).length_m, 80.0);
  EXPECT_LE(ComputeRouteStats(indoor).length_m, 150.0);
  const SceneWithRoute open = BuildOpenScene(1);
  EXPECT_GE(ComputeRouteStats(open).length_m, 600.0);
  EXPECT_LE(ComputeRouteStats(open).length_m, 1000.0);
}

// The rig never starts inside (or next to) geometry: horizontal rays from
// the route at several heights hit nothing closer than 1.5 m; in the 2.4 m
// corridors the walls are 1.2 m away, furniture in the lab >= 1.5 m.
TEST(SceneBuildersTest, RouteIsClearOfGeometry) {
  for (uint64_t seed : {1, 2}) {
    for (const std::string name : {"urban", "open"}) {
      const SceneWithRoute s = BuildScene(name, seed);
      for (const Vector3d& p : RoutePoints(s, 2.0)) {
        ASSERT_GE(NearestAround(s, p), 1.5) << name << " seed " << seed << " at " << p.transpose();
      }
    }
    const SceneWithRoute indoor = BuildIndoorScene(seed);
    const double lab_y0 = indoor.waypoints[3].y() + 1.2;
    for (const Vector3d& p : RoutePoints(indoor, 0.25)) {
      const double nearest = NearestAround(indoor, p);
      EXPECT_GE(nearest, 1.15) << "indoor seed " << seed << " at " << p.transpose();
      if (p.y() > lab_y0 + 0.3) {
        EXPECT_GE(nearest, 1.5) << "lab, seed " << seed << " at " << p.transpose();
      }
    }
  }
}

// The same for the smoothed rig path (corner blends cut the corners) of the
// trajectory generator, at the rig's ground position.
TEST(SceneBuildersTest, RigPathIsClearOfGeometry) {
  for (uint64_t seed : {1, 2}) {
    for (const std::string name : {"urban", "indoor", "open"}) {
      const SceneWithRoute s = BuildScene(name, seed);
      TrajectorySpec spec;
      spec.waypoints = s.waypoints;
      spec.closed = s.route_closed;
      spec.style = s.style;
      spec.speed_mps = s.speed_mps;
      spec.rig_height_m = s.rig_height_m;
      spec.seed = seed;
      const SmoothTrajectory trajectory(spec);
      const int64_t step_ns = s.style == MotionStyle::kHandheld ? 100'000'000 : 200'000'000;
      double nearest = 1e9, nearest_lab = 1e9;
      const double lab_y0 = s.waypoints[3].y() + 1.2;
      for (int64_t t = 0; t < trajectory.DurationNs(); t += step_ns) {
        Vector3d p = trajectory.WorldFromRig(t).translation;
        p.z() = 0.0;
        const double d = NearestAround(s, p);
        nearest = std::min(nearest, d);
        if (name == "indoor" && p.y() > lab_y0 + 0.3) nearest_lab = std::min(nearest_lab, d);
      }
      // Vehicles: 1.5 m. Hand-held: the corridor walls are 1.2 m from the
      // centre line, the sway and bob of the walk take ~0.05 m of it; the
      // lab furniture keeps 1.5 m from the route, the corner blends ~0.2 m of it.
      if (name == "indoor") {
        EXPECT_GE(nearest, 1.0) << name << " seed " << seed;
        EXPECT_GE(nearest_lab, 1.3) << name << " seed " << seed;
      } else {
        EXPECT_GE(nearest, 1.5) << name << " seed " << seed;
      }
    }
  }
}

TEST(SceneBuildersTest, UrbanRouteHasFacadesOnBothSides) {
  const SceneWithRoute s = BuildUrbanScene(4);
  const std::vector<Vector3d> points = RoutePoints(s, 2.0);
  int facade_left = 0, facade_right = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Vector3d& p = points[i];
    const Vector3d forward = (points[(i + 1) % points.size()] - p).normalized();
    const Vector3d left(-forward.y(), forward.x(), 0.0);
    for (int side : {-1, 1}) {
      bool facade = false;
      for (double z : {1.5, 3.0, 5.0}) {
        const auto hit = s.scene.Intersect(p + Vector3d(0, 0, z), side * left, 0, 1e-4, 25.0);
        facade = facade || (hit && IsFacade(hit->quad->material));
      }
      (side > 0 ? facade_left : facade_right) += facade;
    }
  }
  EXPECT_GE(facade_left, 0.6 * points.size());
  EXPECT_GE(facade_right, 0.6 * points.size());
}

// Facades vary per building, but a few designs repeat (same texture seed
// and size) in different streets, as in real cities.
TEST(SceneBuildersTest, UrbanFacadesVaryAndSomeRepeat) {
  const SceneWithRoute s = BuildUrbanScene(2);
  std::map<std::tuple<uint32_t, double, double>, int> designs;
  int facades = 0;
  for (const Quad& q : s.scene.quads()) {
    if (q.material != Material::kFacadeBrick && q.material != Material::kFacadePlaster) continue;
    ++facades;
    ++designs[{q.texture_seed, q.axis_u.norm(), q.axis_v.norm()}];
  }
  int repeated = 0;
  for (const auto& [design, count] : designs) repeated += count > 1 ? count : 0;
  EXPECT_GE(repeated, 10);
  EXPECT_LE(repeated, 0.35 * facades);
}

TEST(SceneBuildersTest, IndoorHasLongPlainWalls) {
  const SceneWithRoute s = BuildIndoorScene(2);
  // Corridor legs: waypoints 0-1, 1-2 and 7-0 (2-3 and 6-7 are cut by the lab).
  int long_runs = 0;
  for (int leg : {0, 1, 7}) {
    const std::vector<Vector3d> points = RoutePoints(s, 0.1, leg, leg + 1);
    const Vector3d forward = (points.back() - points.front()).normalized();
    const Vector3d left(-forward.y(), forward.x(), 0.0);
    for (int side : {-1, 1}) {
      double run = 0.0, longest = 0.0;
      for (const Vector3d& p : points) {
        bool plain = true;
        for (double z : {0.5, 1.4, 2.0}) {
          const auto hit = s.scene.Intersect(p + Vector3d(0, 0, z), side * left, 0);
          plain = plain && hit && hit->quad->material == Material::kWallPaint && hit->distance < 1.3;
        }
        run = plain ? run + 0.1 : 0.0;
        longest = std::max(longest, run);
      }
      long_runs += longest >= 8.0;
    }
  }
  EXPECT_GE(long_runs, 3);
}

TEST(SceneBuildersTest, OpenSceneIsMostlyFarAway) {
  const SceneWithRoute s = BuildOpenScene(3);
  int total = 0, far_or_sky = 0, far_hits = 0;
  for (const Vector3d& p : RoutePoints(s, 20.0)) {
    for (int k = 0; k < 36; ++k) {
      const auto hit = s.scene.Intersect(p + Vector3d(0, 0, s.rig_height_m), Horizontal(k * M_PI / 18), 0);
      ++total;
      far_or_sky += !hit || hit->distance > 150.0;
      far_hits += hit && hit->distance > 150.0;
    }
  }
  EXPECT_GE(far_or_sky, 0.85 * total);
  EXPECT_GE(far_hits, 0.4 * total);  // distant hills in many directions
}

}  // namespace
}  // namespace mcvo::synth
