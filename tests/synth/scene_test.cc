#include "mcvo/synth/scene.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo::synth {
namespace {

using Eigen::Vector3d;

Quad MakeQuad(const Vector3d& origin, const Vector3d& u, const Vector3d& v, uint32_t seed = 0) {
  Quad q;
  q.origin = origin;
  q.axis_u = u;
  q.axis_v = v;
  q.texture_seed = seed;
  return q;
}

TEST(SceneTest, RayQuadHitIsExact) {
  Scene scene;
  // Vertical 4 x 3 m wall in the plane y = 0; front normal u x v = -y.
  scene.AddQuad(MakeQuad({0, 0, 0}, {4, 0, 0}, {0, 0, 3}));
  scene.Build();
  const auto hit = scene.Intersect({1, -5, 2}, {0, 1, 0}, 0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->distance, 5.0);
  EXPECT_EQ(hit->u_m, 1.0);
  EXPECT_EQ(hit->v_m, 2.0);
  EXPECT_EQ(hit->point, Vector3d(1, 0, 2));
  EXPECT_EQ(hit->normal, Vector3d(0, -1, 0));
  EXPECT_EQ(hit->quad, &scene.quads()[0]);
  EXPECT_EQ(hit->moving_object, -1);
  // An oblique ray: from (0, -2, 0) towards (2, 0, 1.5).
  const Vector3d origin(0, -2, 0), target(2, 0, 1.5);
  const auto oblique = scene.Intersect(origin, (target - origin).normalized(), 0);
  ASSERT_TRUE(oblique.has_value());
  EXPECT_NEAR(oblique->distance, (target - origin).norm(), 1e-12);
  EXPECT_NEAR(oblique->u_m, 2.0, 1e-12);
  EXPECT_NEAR(oblique->v_m, 1.5, 1e-12);
}

TEST(SceneTest, TwoSidedNormalFacesTheRayOrigin) {
  Scene scene;
  scene.AddQuad(MakeQuad({0, 0, 0}, {4, 0, 0}, {0, 0, 3}));
  scene.Build();
  const auto back = scene.Intersect({3, 2, 0.5}, {0, -1, 0}, 0);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->distance, 2.0);
  EXPECT_EQ(back->normal, Vector3d(0, 1, 0));
  EXPECT_EQ(back->u_m, 3.0);
  EXPECT_EQ(back->v_m, 0.5);
  const Vector3d d = Vector3d(1, 1, 1).normalized();
  const auto front = scene.Intersect(Vector3d(2, 0, 1) - 3 * d, d, 0);
  ASSERT_TRUE(front.has_value());
  EXPECT_LT(front->normal.dot(d), 0.0);
  EXPECT_NEAR(front->normal.norm(), 1.0, 1e-15);
}

TEST(SceneTest, NearestOfManyAndDistanceBounds) {
  Scene scene;
  for (int k = 3; k >= 1; --k) scene.AddQuad(MakeQuad({-1, 2.0 * k, -1}, {2, 0, 0}, {0, 0, 2}));
  scene.Build();
  const auto hit = scene.Intersect({0, 0, 0}, {0, 1, 0}, 0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->distance, 2.0);
  EXPECT_EQ(hit->quad, &scene.quads()[2]);
  const auto beyond = scene.Intersect({0, 0, 0}, {0, 1, 0}, 0, /*min_distance=*/3.0);
  ASSERT_TRUE(beyond.has_value());
  EXPECT_EQ(beyond->distance, 4.0);
  EXPECT_FALSE(scene.Intersect({0, 0, 0}, {0, 1, 0}, 0, 1e-4, /*max_distance=*/1.5).has_value());
  EXPECT_FALSE(
      scene.Intersect({0, 0, 0}, {0, 1, 0}, 0, 1e-4, /*max_distance=*/2.0).has_value());  // open interval
  EXPECT_FALSE(scene.Intersect({0, 0, 0}, {0, -1, 0}, 0).has_value());                    // behind the origin
}

TEST(SceneTest, MissAndParallelRays) {
  Scene scene;
  scene.AddQuad(MakeQuad({0, 0, 0}, {4, 0, 0}, {0, 0, 3}));
  scene.Build();
  EXPECT_FALSE(scene.Intersect({5, -5, 2}, {0, 1, 0}, 0).has_value());    // beside the quad
  EXPECT_FALSE(scene.Intersect({1, -5, 3.5}, {0, 1, 0}, 0).has_value());  // above
  EXPECT_FALSE(scene.Intersect({-1, 0, 1}, {1, 0, 0}, 0).has_value());    // in the plane
  EXPECT_FALSE(scene.Intersect({-1, -1, 1}, {1, 0, 0}, 0).has_value());   // parallel to the plane
  Scene empty;
  empty.Build();
  EXPECT_FALSE(empty.Intersect({0, 0, 0}, {1, 0, 0}, 0).has_value());
}

TEST(SceneTest, BoxFacesPointOutwardsWithAxisVUp) {
  BoxSpec box;
  box.center = {10, 5, 0};
  box.yaw_rad = 0.3;
  box.size = {4, 2, 3};
  box.with_bottom = true;
  box.texture_seed = 42;
  const std::vector<Quad> quads = MakeBoxQuads(box);
  ASSERT_EQ(quads.size(), 6u);
  const Vector3d box_centre = box.center + Vector3d(0, 0, 1.5);
  for (int k = 0; k < 6; ++k) {
    const Quad& q = quads[k];
    const Vector3d normal = q.axis_u.cross(q.axis_v).normalized();
    const Vector3d face_centre = q.origin + 0.5 * (q.axis_u + q.axis_v);
    EXPECT_GT(normal.dot(face_centre - box_centre), 0.0) << "face " << k;
    EXPECT_NEAR(q.axis_u.dot(q.axis_v), 0.0, 1e-12);
    if (k < 4) {
      EXPECT_NEAR(q.axis_v.z(), 3.0, 1e-12);
    }
    EXPECT_EQ(q.texture_seed, BoxFaceSeed(42, k));
  }
  // +x face (k = 0) faces the yaw direction.
  EXPECT_NEAR(
      quads[0].axis_u.cross(quads[0].axis_v).normalized().dot(Vector3d(std::cos(0.3), std::sin(0.3), 0)), 1.0,
      1e-12);
  // A yaw of 90 degrees keeps the faces exactly axis aligned.
  box.yaw_rad = M_PI / 2;
  for (const Quad& q : MakeBoxQuads(box)) {
    EXPECT_EQ((q.axis_u.array() != 0.0).count(), 1);
    EXPECT_EQ((q.axis_v.array() != 0.0).count(), 1);
  }
  Scene scene;
  box.yaw_rad = 0.0;
  scene.AddBox(box);
  scene.Build();
  const auto hit = scene.Intersect({20, 5, 1}, {-1, 0, 0}, 0);  // +x face at x = 12
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->distance, 8.0);
  EXPECT_EQ(hit->quad, &scene.quads()[0]);
  EXPECT_EQ(hit->normal, Vector3d(1, 0, 0));
}

TEST(SceneTest, MovingObjectPingPongs) {
  MovingObject object;
  object.start_in_world = {0, 10, 0};
  object.end_in_world = {20, 10, 0};
  object.speed_mps = 5.0;  // 4 s from start to end
  object.yaw_rad = 0.0;
  BoxSpec box;
  box.size = {2, 2, 2};
  object.quads_in_object = MakeBoxQuads(box);
  const auto position = [&](double t_s) {
    return object.WorldFromObject(static_cast<int64_t>(std::llround(t_s * 1e9))).translation;
  };
  EXPECT_TRUE(position(0).isApprox(Vector3d(0, 10, 0)));
  EXPECT_TRUE(position(2).isApprox(Vector3d(10, 10, 0)));
  EXPECT_TRUE(position(4).isApprox(Vector3d(20, 10, 0)));
  EXPECT_TRUE(position(6).isApprox(Vector3d(10, 10, 0)));  // on the way back
  EXPECT_TRUE(position(8.5).isApprox(Vector3d(2.5, 10, 0)));
  EXPECT_TRUE(position(-1).isApprox(Vector3d(5, 10, 0)));
  // No teleport: consecutive 10 ms steps move at most speed * dt.
  for (double t = 0; t < 20; t += 0.01) EXPECT_LE((position(t + 0.01) - position(t)).norm(), 0.05 + 1e-9);

  Scene scene;
  scene.AddQuad(MakeQuad({-50, 20, 0}, {100, 0, 0}, {0, 0, 10}));  // a wall behind the object
  scene.AddMovingObject(object);
  scene.Build();
  // Looking along +y from x = 0: the object (its -y face at y = 9) at t = 0, the wall at t = 2 s.
  const auto at_start = scene.Intersect({0, 0, 1}, {0, 1, 0}, 0);
  ASSERT_TRUE(at_start.has_value());
  EXPECT_EQ(at_start->moving_object, 0);
  EXPECT_NEAR(at_start->distance, 9.0, 1e-12);
  EXPECT_NEAR(at_start->normal.y(), -1.0, 1e-12);
  EXPECT_EQ(at_start->quad, &scene.moving_objects()[0].quads_in_object[3]);
  const auto later = scene.Intersect({0, 0, 1}, {0, 1, 0}, 2'000'000'000);
  ASSERT_TRUE(later.has_value());
  EXPECT_EQ(later->moving_object, -1);
  EXPECT_EQ(later->distance, 20.0);
  // At t = 2 s the object is at x = 10.
  const auto moved = scene.Intersect({10, 0, 1}, {0, 1, 0}, 2'000'000'000);
  ASSERT_TRUE(moved.has_value());
  EXPECT_EQ(moved->moving_object, 0);
  EXPECT_NEAR(moved->point.y(), 9.0, 1e-12);
  EXPECT_NEAR(moved->u_m, 1.0, 1e-9);  // -y face, u along +x from the corner at x = -1
  EXPECT_NEAR(moved->v_m, 1.0, 1e-9);
}

// Random rays: from inside the city at street and roof level, and from far above.
std::vector<std::pair<Vector3d, Vector3d>> RandomRays(const SceneWithRoute& s, int n, uint64_t seed) {
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), z(0.2, 40.0);
  Vector3d lo = Vector3d::Constant(1e9), hi = -lo;
  for (const Vector3d& w : s.waypoints) {
    lo = lo.cwiseMin(w);
    hi = hi.cwiseMax(w);
  }
  std::vector<std::pair<Vector3d, Vector3d>> rays;
  while (static_cast<int>(rays.size()) < n) {
    Vector3d d(unit(gen), unit(gen), unit(gen));
    if (d.norm() < 0.1 || d.norm() > 1.0) continue;
    Vector3d o;
    for (int k = 0; k < 2; ++k) o[k] = lo[k] - 50 + (hi[k] - lo[k] + 100) * 0.5 * (unit(gen) + 1.0);
    o.z() = z(gen);
    // Every tenth ray is exactly axis aligned (zero direction components).
    if (rays.size() % 10 == 0)
      d = Vector3d::Unit(static_cast<int>(rays.size() / 10) % 3) * (unit(gen) < 0 ? -1 : 1);
    rays.emplace_back(o, d.normalized());
  }
  return rays;
}

TEST(SceneTest, BvhMatchesBruteForceOnUrbanScene) {
  const SceneWithRoute s = BuildUrbanScene(3);
  int hits = 0;
  for (const auto& [o, d] : RandomRays(s, 4000, 11)) {
    for (int64_t t_ns : {int64_t{0}, int64_t{7'300'000'000}}) {
      const auto fast = s.scene.Intersect(o, d, t_ns);
      const auto slow = s.scene.IntersectBruteForce(o, d, t_ns);
      ASSERT_EQ(fast.has_value(), slow.has_value()) << o.transpose() << " / " << d.transpose();
      if (!fast) continue;
      ++hits;
      EXPECT_EQ(fast->quad, slow->quad);
      EXPECT_EQ(fast->distance, slow->distance);
      EXPECT_EQ(fast->u_m, slow->u_m);
      EXPECT_EQ(fast->v_m, slow->v_m);
      EXPECT_EQ(fast->moving_object, slow->moving_object);
      EXPECT_EQ(fast->normal, slow->normal);
    }
  }
  EXPECT_GT(hits, 4000);  // most rays hit something (ground, buildings)
}

TEST(SceneTest, BuildingTwiceIsIdentical) {
  const SceneWithRoute a = BuildUrbanScene(5), b = BuildUrbanScene(5);
  ASSERT_EQ(a.scene.quads().size(), b.scene.quads().size());
  for (size_t i = 0; i < a.scene.quads().size(); ++i) {
    const Quad& qa = a.scene.quads()[i];
    const Quad& qb = b.scene.quads()[i];
    ASSERT_EQ(qa.origin, qb.origin);
    ASSERT_EQ(qa.axis_u, qb.axis_u);
    ASSERT_EQ(qa.axis_v, qb.axis_v);
    ASSERT_EQ(qa.material, qb.material);
    ASSERT_EQ(qa.texture_seed, qb.texture_seed);
  }
  ASSERT_EQ(a.waypoints, b.waypoints);
  for (const auto& [o, d] : RandomRays(a, 1000, 2)) {
    const auto ha = a.scene.Intersect(o, d, 1'000'000'000), hb = b.scene.Intersect(o, d, 1'000'000'000);
    ASSERT_EQ(ha.has_value(), hb.has_value());
    if (!ha) continue;
    EXPECT_EQ(ha->distance, hb->distance);
    ASSERT_EQ(ha->moving_object, hb->moving_object);
    if (ha->moving_object < 0) {
      EXPECT_EQ(ha->quad - a.scene.quads().data(), hb->quad - b.scene.quads().data());
    }
    EXPECT_EQ(ha->u_m, hb->u_m);
  }
  // Another seed gives another city.
  EXPECT_NE(BuildUrbanScene(6).waypoints, a.waypoints);
}

TEST(SceneTest, WriteSceneCsvIsCompleteAndDeterministic) {
  Scene scene;
  scene.AddQuad(MakeQuad({0.1, 0, 0}, {4, 0, 0}, {0, 0, 3}, 77));
  BoxSpec box;
  box.side_material = Material::kFacadeBrick;
  scene.AddBox(box);
  scene.Build();
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "mcvo_scene_csv_test";
  std::filesystem::create_directories(dir);
  WriteSceneCsv(dir / "a.csv", scene);
  WriteSceneCsv(dir / "b.csv", scene);
  const std::string a = ReadFileToString(dir / "a.csv");
  EXPECT_EQ(a, ReadFileToString(dir / "b.csv"));
  std::vector<std::string> lines;
  for (std::string_view rest = a; !rest.empty();) {
    const size_t end = rest.find('\n');
    ASSERT_NE(end, std::string_view::npos);  // every line complete
    lines.emplace_back(rest.substr(0, end));
    rest.remove_prefix(end + 1);
  }
  ASSERT_EQ(lines.size(), 1 + scene.quads().size());
  EXPECT_EQ(lines[1], "0,asphalt,0.1,0,0,4,0,0,0,0,3,77");
  EXPECT_EQ(SplitFields(lines[2], ',').size(), 12u);
  EXPECT_EQ(SplitFields(lines[2], ',')[1], "facade_brick");
  std::filesystem::remove_all(dir);
}

TEST(SceneTest, MaterialNamesAreUnique) {
  std::vector<std::string> names;
  for (int k = 0; k < kNumMaterials; ++k) names.emplace_back(MaterialName(static_cast<Material>(k)));
  for (size_t i = 0; i < names.size(); ++i) {
    EXPECT_FALSE(names[i].empty());
    for (size_t j = i + 1; j < names.size(); ++j) EXPECT_NE(names[i], names[j]);
  }
}

// Throughput of camera-like rays on the urban scene (not a timed test; run
// with --gtest_also_run_disabled_tests to print rays/s).
TEST(SceneTest, DISABLED_Throughput) {
  const SceneWithRoute s = BuildUrbanScene(1);
  std::vector<std::pair<Vector3d, Vector3d>> rays;
  std::mt19937_64 gen(1);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int i = 0; i < 1'000'000; ++i) {
    const Vector3d& w0 = s.waypoints[i % s.waypoints.size()];
    const Vector3d& w1 = s.waypoints[(i + 1) % s.waypoints.size()];
    const Vector3d o = w0 + 0.5 * (unit(gen) + 1) * (w1 - w0) + Vector3d(0, 0, 1.5);
    Vector3d d(unit(gen), unit(gen), 0.5 * unit(gen));
    rays.emplace_back(o, d.normalized());
  }
  const auto start = std::chrono::steady_clock::now();
  int hits = 0;
  for (const auto& [o, d] : rays) hits += s.scene.Intersect(o, d, 0).has_value();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%zu quads, %d BVH nodes: %.0f rays/s (%.3f us/ray), %d hits\n", s.scene.quads().size(),
              s.scene.num_bvh_nodes(), rays.size() / seconds, 1e6 * seconds / rays.size(), hits);
}

}  // namespace
}  // namespace mcvo::synth
