// Shared helpers of the scene builders and the by-name dispatch.
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"
#include "scene_build_util.h"

namespace mcvo::synth {
namespace internal {

Quad VerticalQuad(const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, double z0, double height,
                  Material material, uint32_t seed) {
  Quad q;
  q.origin = Eigen::Vector3d(p0.x(), p0.y(), z0);
  q.axis_u = Eigen::Vector3d(p1.x() - p0.x(), p1.y() - p0.y(), 0.0);
  q.axis_v = Eigen::Vector3d(0.0, 0.0, height);
  q.material = material;
  q.texture_seed = seed;
  return q;
}

Quad HorizontalQuad(double x0, double y0, double x1, double y1, double z, Material material, uint32_t seed,
                    bool facing_down) {
  Quad q;
  q.origin = Eigen::Vector3d(x0, y0, z);
  q.axis_u = Eigen::Vector3d(x1 - x0, 0.0, 0.0);
  q.axis_v = Eigen::Vector3d(0.0, y1 - y0, 0.0);
  if (facing_down) std::swap(q.axis_u, q.axis_v);  // y x x = -z
  q.material = material;
  q.texture_seed = seed;
  return q;
}

Quad StripQuad(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double width, double z, Material material,
               uint32_t seed) {
  const Eigen::Vector2d dir = (b - a).normalized();
  const Eigen::Vector2d left(-dir.y(), dir.x());
  const Eigen::Vector2d origin = a - 0.5 * width * left;
  Quad q;
  q.origin = Eigen::Vector3d(origin.x(), origin.y(), z);
  q.axis_u = Eigen::Vector3d(b.x() - a.x(), b.y() - a.y(), 0.0);
  q.axis_v = Eigen::Vector3d(width * left.x(), width * left.y(), 0.0);
  q.material = material;
  q.texture_seed = seed;
  return q;
}

namespace {

double SegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + s * ab - p).norm();
}

// Distance between two segments in the plane (0 when they cross).
double SegmentSegmentDistance(const Eigen::Vector2d& a0, const Eigen::Vector2d& a1, const Eigen::Vector2d& b0,
                              const Eigen::Vector2d& b1) {
  const auto orient = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r) {
    const Eigen::Vector2d u = q - p, v = r - p;
    return u.x() * v.y() - u.y() * v.x();
  };
  const double d1 = orient(a0, a1, b0), d2 = orient(a0, a1, b1), d3 = orient(b0, b1, a0),
               d4 = orient(b0, b1, a1);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return 0.0;
  return std::min({SegmentDistance(a0, b0, b1), SegmentDistance(a1, b0, b1), SegmentDistance(b0, a0, a1),
                   SegmentDistance(b1, a0, a1)});
}

}  // namespace

double DistanceToRoute(const Eigen::Vector2d& p, const std::vector<Eigen::Vector3d>& waypoints, bool closed) {
  const int n = static_cast<int>(waypoints.size());
  double best = n == 1 ? (waypoints[0].head<2>() - p).norm() : 1e300;
  const int segments = closed ? n : n - 1;
  for (int i = 0; i < segments; ++i) {
    best = std::min(best, SegmentDistance(p, waypoints[i].head<2>(), waypoints[(i + 1) % n].head<2>()));
  }
  return best;
}

double BoxDistanceToRoute(const BoxSpec& box, const std::vector<Eigen::Vector3d>& waypoints, bool closed) {
  const Eigen::Vector2d c = box.center.head<2>();
  const Eigen::Vector2d ex(std::cos(box.yaw_rad), std::sin(box.yaw_rad));
  const Eigen::Vector2d ey(-ex.y(), ex.x());
  const double hx = 0.5 * box.size.x(), hy = 0.5 * box.size.y();
  const Eigen::Vector2d corners[4] = {c + hx * ex + hy * ey, c - hx * ex + hy * ey, c - hx * ex - hy * ey,
                                      c + hx * ex - hy * ey};
  const int n = static_cast<int>(waypoints.size());
  const int segments = closed ? n : n - 1;
  double best = 1e300;
  for (int i = 0; i < segments; ++i) {
    const Eigen::Vector2d a = waypoints[i].head<2>(), b = waypoints[(i + 1) % n].head<2>();
    // Inside the footprint: distance 0.
    const Eigen::Vector2d rel = a - c;
    if (std::abs(rel.dot(ex)) <= hx && std::abs(rel.dot(ey)) <= hy) return 0.0;
    for (int k = 0; k < 4; ++k)
      best = std::min(best, SegmentSegmentDistance(a, b, corners[k], corners[(k + 1) % 4]));
  }
  return best;
}

std::vector<BoxSpec> CarBoxes(const Eigen::Vector2d& center, double yaw_rad, SceneRng* rng) {
  const uint32_t seed = rng->Seed32();
  const double length = rng->Uniform(3.9, 4.8), width = rng->Uniform(1.7, 1.9);
  BoxSpec body;
  body.center = Eigen::Vector3d(center.x(), center.y(), 0.25);
  body.yaw_rad = yaw_rad;
  body.size = Eigen::Vector3d(length, width, 0.8);
  body.side_material = Material::kMetal;
  body.top_material = Material::kMetal;
  body.with_bottom = true;
  body.texture_seed = seed;
  BoxSpec cabin = body;
  const Eigen::Vector2d back(-0.1 * length * std::cos(yaw_rad), -0.1 * length * std::sin(yaw_rad));
  cabin.center = Eigen::Vector3d(center.x() + back.x(), center.y() + back.y(), 1.05);
  cabin.size = Eigen::Vector3d(0.5 * length, width - 0.15, rng->Uniform(0.45, 0.6));
  cabin.with_bottom = false;
  cabin.texture_seed = seed + 1;
  return {body, cabin};
}

std::vector<Quad> CarQuadsInObject(SceneRng* rng) {
  std::vector<Quad> quads;
  for (const BoxSpec& box : CarBoxes(Eigen::Vector2d::Zero(), 0.0, rng)) {
    for (const Quad& q : MakeBoxQuads(box)) quads.push_back(q);
  }
  return quads;
}

std::vector<BoxSpec> TreeBoxes(const Eigen::Vector2d& center, double crown_size, double height,
                               SceneRng* rng) {
  BoxSpec trunk;
  trunk.center = Eigen::Vector3d(center.x(), center.y(), 0.0);
  trunk.yaw_rad = rng->Uniform(0.0, 1.5);
  trunk.size = Eigen::Vector3d(0.3, 0.3, 0.45 * height + 0.3);
  trunk.side_material = Material::kWood;
  trunk.top_material = Material::kWood;
  trunk.texture_seed = rng->Seed32();
  BoxSpec crown;
  crown.center = Eigen::Vector3d(center.x(), center.y(), 0.45 * height);
  crown.yaw_rad = rng->Uniform(0.0, 1.5);
  crown.size = Eigen::Vector3d(crown_size, crown_size * rng->Uniform(0.8, 1.0), 0.55 * height);
  crown.side_material = Material::kFoliage;
  crown.top_material = Material::kFoliage;
  crown.with_bottom = true;
  crown.texture_seed = rng->Seed32();
  return {trunk, crown};
}

}  // namespace internal

const std::vector<std::string>& SceneNames() {
  static const std::vector<std::string> names = {
      "urban",  "urban_block", "urban_small_block", "urban_repeated", "urban_small_repeated",
      "indoor", "open"};
  return names;
}

SceneWithRoute BuildScene(const std::string& name, uint64_t seed) {
  if (name == "urban") return BuildUrbanScene(seed);
  if (name == "urban_block") return BuildUrbanBlockScene(seed);
  if (name == "urban_small_block") return BuildUrbanSmallBlockScene(seed);
  if (name == "urban_repeated") return BuildUrbanRepeatedScene(seed);
  if (name == "urban_small_repeated") return BuildUrbanSmallRepeatedScene(seed);
  if (name == "indoor") return BuildIndoorScene(seed);
  if (name == "open") return BuildOpenScene(seed);
  std::string known;
  for (const std::string& known_name : SceneNames()) known += (known.empty() ? "" : ", ") + known_name;
  throw InputError("unknown scene '" + name + "' (known: " + known + ")");
}

void WriteSceneCsv(const std::filesystem::path& path, const Scene& scene) {
  AtomicFileWriter writer(path);
  std::ostream& out = writer.stream();
  out << "index,material,origin_x,origin_y,origin_z,axis_u_x,axis_u_y,axis_u_z,axis_v_x,axis_v_y,axis_v_z,"
         "texture_seed\n";
  const std::vector<Quad>& quads = scene.quads();
  for (size_t i = 0; i < quads.size(); ++i) {
    const Quad& q = quads[i];
    out << i << ',' << MaterialName(q.material);
    for (const Eigen::Vector3d* v : {&q.origin, &q.axis_u, &q.axis_v}) {
      for (int k = 0; k < 3; ++k) out << ',' << FormatDouble((*v)[k]);
    }
    out << ',' << q.texture_seed << '\n';
  }
  writer.Commit();
}

RouteStats ComputeRouteStats(const SceneWithRoute& scene) {
  RouteStats stats;
  const std::vector<Eigen::Vector3d>& w = scene.waypoints;
  const int n = static_cast<int>(w.size());
  if (n < 2) return stats;
  const int segments = scene.route_closed ? n : n - 1;
  for (int i = 0; i < segments; ++i) stats.length_m += (w[(i + 1) % n] - w[i]).norm();
  const double min_turn = 30.0 * 3.14159265358979323846 / 180.0;
  for (int i = 0; i < n; ++i) {
    if (!scene.route_closed && (i == 0 || i == n - 1)) continue;
    const Eigen::Vector3d in = w[i] - w[(i + n - 1) % n], out = w[(i + 1) % n] - w[i];
    const double cross = in.x() * out.y() - in.y() * out.x(), dot = in.x() * out.x() + in.y() * out.y();
    const double angle = std::atan2(cross, dot);
    if (angle > min_turn) ++stats.left_turns;
    if (angle < -min_turn) ++stats.right_turns;
  }
  return stats;
}

std::string SceneSummary(const SceneWithRoute& scene) {
  std::map<std::string_view, int> per_material;
  for (const Quad& q : scene.scene.quads()) ++per_material[MaterialName(q.material)];
  const RouteStats stats = ComputeRouteStats(scene);
  std::ostringstream out;
  out << scene.name << ": " << scene.scene.quads().size() << " quads, " << scene.scene.moving_objects().size()
      << " moving objects, route " << FormatFixed(stats.length_m, 1) << " m "
      << (scene.route_closed ? "closed" : "open") << " (" << scene.waypoints.size() << " waypoints, "
      << stats.left_turns << " left / " << stats.right_turns << " right turns); quads per material:";
  for (const auto& [name, count] : per_material) out << ' ' << name << '=' << count;
  return out.str();
}

}  // namespace mcvo::synth
