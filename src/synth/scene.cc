// Scene: quads, boxes, moving objects, the BVH and the ray queries.
//
// BVH: binary tree built top-down with the surface area heuristic (SAH),
// evaluated exactly by sweeping the quads sorted by centroid (ties broken by
// quad index, so the tree depends only on the quads and their order). Node
// boxes are float, padded and rounded outwards, so the float slab test is
// conservative; the ray-quad test that decides the hit is in double.
#include "mcvo/synth/scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "mcvo/util/error.h"
#include "mcvo/util/hash.h"

namespace mcvo::synth {

std::string_view MaterialName(Material material) {
  switch (material) {
    case Material::kSky:
      return "sky";
    case Material::kAsphalt:
      return "asphalt";
    case Material::kRoadMarking:
      return "road_marking";
    case Material::kSidewalk:
      return "sidewalk";
    case Material::kFacadePlaster:
      return "facade_plaster";
    case Material::kFacadeBrick:
      return "facade_brick";
    case Material::kShopFront:
      return "shop_front";
    case Material::kPoster:
      return "poster";
    case Material::kWallPaint:
      return "wall_paint";
    case Material::kFloorTile:
      return "floor_tile";
    case Material::kCeiling:
      return "ceiling";
    case Material::kWood:
      return "wood";
    case Material::kMetal:
      return "metal";
    case Material::kGrass:
      return "grass";
    case Material::kRock:
      return "rock";
    case Material::kFoliage:
      return "foliage";
    case Material::kMarker:
      return "marker";
  }
  return "unknown";
}

namespace {

// Box padding: absorbs the float rounding of ray origins and slab distances
// for coordinates up to ~10 km.
constexpr double kBoxPadAbs = 1e-2;
constexpr double kBoxPadRel = 4e-6;
// Rectangle coordinates a, b are accepted in [-eps, 1 + eps], so rays through
// a shared edge never slip between two quads.
constexpr double kEdgeEps = 1e-7;
constexpr int kMaxLeafSize = 4;
constexpr int kMedianSplitDepth = 40;  // below this depth: median split (bounds the depth)
constexpr int kStackSize = 64;

// Cosine and sine with exact values at multiples of 90 degrees, so boxes
// built with such yaws stay exactly axis aligned.
void SnappedCosSin(double angle, double* c, double* s) {
  *c = std::cos(angle);
  *s = std::sin(angle);
  for (double* v : {c, s}) {
    if (std::abs(*v) < 1e-12) *v = 0.0;
    if (std::abs(std::abs(*v) - 1.0) < 1e-12) *v = std::copysign(1.0, *v);
  }
}

float RoundDown(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) > v ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
float RoundUp(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) < v ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

struct BuildItem {
  Eigen::Vector3d box_min, box_max, centroid;
  int accel = 0;  // index into the unordered accel list
};

double HalfArea(const Eigen::Vector3d& box_min, const Eigen::Vector3d& box_max) {
  const Eigen::Vector3d e = (box_max - box_min).cwiseMax(0.0);
  return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
}

// Inverse direction without infinities or NaN: a zero component becomes a
// huge finite value of the same sign, so 0 * inv is 0 and signs stay right.
float SafeInverse(double d) {
  if (std::abs(d) < 1e-20) return std::copysign(1e30f, d);
  return static_cast<float>(1.0 / d);
}

}  // namespace

uint32_t BoxFaceSeed(uint32_t box_seed, int face) {
  return Mix32(box_seed * 0x9E3779B9U + static_cast<uint32_t>(face) * 0x85EBCA6BU + 0x27D4EB2FU);
}

std::vector<Quad> MakeBoxQuads(const BoxSpec& box) {
  MCVO_CHECK_MSG(box.size.minCoeff() > 0.0, "box size ", box.size.transpose());
  double c = 1.0, s = 0.0;
  SnappedCosSin(box.yaw_rad, &c, &s);
  const auto rotate = [&](double x, double y, double z) {
    return Eigen::Vector3d(c * x - s * y, s * x + c * y, z);
  };
  const double hx = 0.5 * box.size.x(), hy = 0.5 * box.size.y(), h = box.size.z();
  const Eigen::Vector3d up(0.0, 0.0, h);
  std::vector<Quad> quads;
  const auto add = [&](const Eigen::Vector3d& origin_in_box, const Eigen::Vector3d& u,
                       const Eigen::Vector3d& v, Material material) {
    Quad q;
    q.origin = box.center + rotate(origin_in_box.x(), origin_in_box.y(), origin_in_box.z());
    q.axis_u = rotate(u.x(), u.y(), u.z());
    q.axis_v = rotate(v.x(), v.y(), v.z());
    q.material = material;
    q.texture_seed = BoxFaceSeed(box.texture_seed, static_cast<int>(quads.size()));
    quads.push_back(q);
  };
  // Sides: axis_v up, outward normal axis_u x axis_v.
  add({hx, -hy, 0}, {0, 2 * hy, 0}, up, box.side_material);              // +x
  add({hx, hy, 0}, {-2 * hx, 0, 0}, up, box.side_material);              // +y
  add({-hx, hy, 0}, {0, -2 * hy, 0}, up, box.side_material);             // -x
  add({-hx, -hy, 0}, {2 * hx, 0, 0}, up, box.side_material);             // -y
  add({-hx, -hy, h}, {2 * hx, 0, 0}, {0, 2 * hy, 0}, box.top_material);  // top, normal +z
  if (box.with_bottom) add({-hx, -hy, 0}, {0, 2 * hy, 0}, {2 * hx, 0, 0}, box.side_material);  // normal -z
  return quads;
}

Rigid3d MovingObject::WorldFromObject(int64_t t_ns) const {
  const Eigen::Quaterniond rotation(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
  const Eigen::Vector3d path = end_in_world - start_in_world;
  const double length = path.norm();
  if (length < 1e-9 || speed_mps <= 0.0) return Rigid3d(rotation, start_in_world);
  // Ping-pong: s in [0, 2 L) is the distance along the out-and-back cycle.
  const double travelled = speed_mps * (static_cast<double>(t_ns) * 1e-9);
  double s = std::fmod(travelled, 2.0 * length);
  if (s < 0.0) s += 2.0 * length;
  const double along = s <= length ? s : 2.0 * length - s;
  return Rigid3d(rotation, start_in_world + path * (along / length));
}

int Scene::AddQuad(const Quad& quad) {
  const double lu = quad.axis_u.norm(), lv = quad.axis_v.norm();
  MCVO_CHECK_MSG(lu > 0.0 && lv > 0.0 && std::isfinite(lu) && std::isfinite(lv) && quad.origin.allFinite(),
                 "degenerate quad");
  MCVO_CHECK_MSG(std::abs(quad.axis_u.dot(quad.axis_v)) <= 1e-9 * lu * lv, "quad axes not orthogonal");
  quads_.push_back(quad);
  built_ = false;
  return static_cast<int>(quads_.size()) - 1;
}

void Scene::AddBox(const BoxSpec& box) {
  for (const Quad& q : MakeBoxQuads(box)) AddQuad(q);
}

void Scene::AddMovingObject(MovingObject object) {
  for (const Quad& q : object.quads_in_object) {
    MCVO_CHECK(q.axis_u.norm() > 0.0 && q.axis_v.norm() > 0.0);
    MCVO_CHECK(std::abs(q.axis_u.dot(q.axis_v)) <= 1e-9 * q.axis_u.norm() * q.axis_v.norm());
  }
  moving_objects_.push_back(std::move(object));
  built_ = false;
}

Scene::QuadAccel Scene::MakeAccel(const Quad& quad, int index) {
  QuadAccel a;
  a.origin = quad.origin;
  a.normal = quad.axis_u.cross(quad.axis_v).normalized();
  a.length_u = quad.axis_u.norm();
  a.length_v = quad.axis_v.norm();
  a.dual_u = quad.axis_u / (a.length_u * a.length_u);
  a.dual_v = quad.axis_v / (a.length_v * a.length_v);
  a.index = index;
  return a;
}

void Scene::Build() {
  const int n = static_cast<int>(quads_.size());
  std::vector<BuildItem> items(n);
  for (int i = 0; i < n; ++i) {
    const Quad& q = quads_[i];
    BuildItem& it = items[i];
    it.box_min = q.origin;
    it.box_max = q.origin;
    for (const Eigen::Vector3d& corner :
         {Eigen::Vector3d(q.origin + q.axis_u), Eigen::Vector3d(q.origin + q.axis_v),
          Eigen::Vector3d(q.origin + q.axis_u + q.axis_v)}) {
      it.box_min = it.box_min.cwiseMin(corner);
      it.box_max = it.box_max.cwiseMax(corner);
    }
    it.centroid = q.origin + 0.5 * (q.axis_u + q.axis_v);
    it.accel = i;
  }
  nodes_.clear();
  accel_.clear();
  accel_.reserve(n);
  if (n > 0) {
    nodes_.reserve(static_cast<size_t>(2) * n);
    nodes_.emplace_back();
    // Explicit work list of (node, begin, end, depth); children are created
    // in pairs so that right = left + 1.
    struct Task {
      int node, begin, end, depth;
    };
    std::vector<Task> tasks = {{0, 0, n, 0}};
    std::vector<double> right_area(n + 1);
    while (!tasks.empty()) {
      const Task task = tasks.back();
      tasks.pop_back();
      Eigen::Vector3d box_min = items[task.begin].box_min, box_max = items[task.begin].box_max;
      for (int i = task.begin + 1; i < task.end; ++i) {
        box_min = box_min.cwiseMin(items[i].box_min);
        box_max = box_max.cwiseMax(items[i].box_max);
      }
      const Eigen::Vector3d pad = Eigen::Vector3d::Constant(kBoxPadAbs) +
                                  kBoxPadRel * box_min.cwiseAbs().cwiseMax(box_max.cwiseAbs());
      Node& node = nodes_[task.node];
      for (int k = 0; k < 3; ++k) {
        node.box_min[k] = RoundDown(box_min[k] - pad[k]);
        node.box_max[k] = RoundUp(box_max[k] + pad[k]);
      }
      const int count = task.end - task.begin;
      const auto make_leaf = [&] {
        Node& leaf = nodes_[task.node];
        leaf.first = static_cast<int>(accel_.size());
        leaf.count = count;
        for (int i = task.begin; i < task.end; ++i)
          accel_.push_back(MakeAccel(quads_[items[i].accel], items[i].accel));
      };
      if (count <= kMaxLeafSize) {
        make_leaf();
        continue;
      }
      const auto by_axis = [](int axis) {
        return [axis](const BuildItem& a, const BuildItem& b) {
          if (a.centroid[axis] != b.centroid[axis]) return a.centroid[axis] < b.centroid[axis];
          return a.accel < b.accel;
        };
      };
      int best_axis = 0, best_split = task.begin + count / 2;
      if (task.depth < kMedianSplitDepth) {
        // SAH sweep over the three axes: cost ~ area_left * n_left + area_right * n_right.
        double best_cost = std::numeric_limits<double>::infinity();
        for (int axis = 0; axis < 3; ++axis) {
          std::sort(items.begin() + task.begin, items.begin() + task.end, by_axis(axis));
          Eigen::Vector3d rmin = items[task.end - 1].box_min, rmax = items[task.end - 1].box_max;
          for (int i = task.end - 1; i > task.begin; --i) {
            rmin = rmin.cwiseMin(items[i].box_min);
            rmax = rmax.cwiseMax(items[i].box_max);
            right_area[i - task.begin] = HalfArea(rmin, rmax);
          }
          Eigen::Vector3d lmin = items[task.begin].box_min, lmax = items[task.begin].box_max;
          for (int i = task.begin + 1; i < task.end; ++i) {  // split before item i
            const int n_left = i - task.begin;
            const double cost = HalfArea(lmin, lmax) * n_left + right_area[n_left] * (count - n_left);
            if (cost < best_cost) {
              best_cost = cost;
              best_axis = axis;
              best_split = i;
            }
            lmin = lmin.cwiseMin(items[i].box_min);
            lmax = lmax.cwiseMax(items[i].box_max);
          }
        }
      } else {
        const Eigen::Vector3d extent = box_max - box_min;
        extent.maxCoeff(&best_axis);
      }
      std::sort(items.begin() + task.begin, items.begin() + task.end, by_axis(best_axis));
      const int left = static_cast<int>(nodes_.size());
      nodes_[task.node].first = left;
      nodes_[task.node].count = 0;
      nodes_.emplace_back();
      nodes_.emplace_back();
      // Right pushed first so the left subtree is laid out first (locality).
      tasks.push_back({left + 1, best_split, task.end, task.depth + 1});
      tasks.push_back({left, task.begin, best_split, task.depth + 1});
    }
  }
  moving_accel_.clear();
  for (const MovingObject& object : moving_objects_) {
    MovingAccel m;
    m.box_min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    m.box_max = -m.box_min;
    for (int i = 0; i < static_cast<int>(object.quads_in_object.size()); ++i) {
      const Quad& q = object.quads_in_object[i];
      m.quads.push_back(MakeAccel(q, i));
      for (const Eigen::Vector3d& p :
           {Eigen::Vector3d(q.origin), Eigen::Vector3d(q.origin + q.axis_u),
            Eigen::Vector3d(q.origin + q.axis_v), Eigen::Vector3d(q.origin + q.axis_u + q.axis_v)}) {
        m.box_min = m.box_min.cwiseMin(p);
        m.box_max = m.box_max.cwiseMax(p);
      }
    }
    m.box_min.array() -= kBoxPadAbs;
    m.box_max.array() += kBoxPadAbs;
    // World box swept along the path: the object's box corners at both ends
    // (the motion is a translation, the yaw is constant).
    m.swept_min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    m.swept_max = -m.swept_min;
    if (!m.quads.empty()) {
      for (const Eigen::Vector3d& position : {object.start_in_world, object.end_in_world}) {
        const Rigid3d world_from_object(
            Eigen::Quaterniond(Eigen::AngleAxisd(object.yaw_rad, Eigen::Vector3d::UnitZ())), position);
        for (int corner = 0; corner < 8; ++corner) {
          const Eigen::Vector3d c((corner & 1) ? m.box_max.x() : m.box_min.x(),
                                  (corner & 2) ? m.box_max.y() : m.box_min.y(),
                                  (corner & 4) ? m.box_max.z() : m.box_min.z());
          const Eigen::Vector3d p = world_from_object * c;
          m.swept_min = m.swept_min.cwiseMin(p);
          m.swept_max = m.swept_max.cwiseMax(p);
        }
      }
      m.swept_min.array() -= kBoxPadAbs;
      m.swept_max.array() += kBoxPadAbs;
    }
    moving_accel_.push_back(std::move(m));
  }
  built_ = true;
}

namespace {

// The nearest hit found so far: distance, quad and rectangle coordinates.
struct Candidate {
  double t;
  int index = -1;
  const void* accel = nullptr;
  double a = 0.0, b = 0.0, denom = 0.0;
};

// Ray against one prepared quad; updates `best` when nearer (ties: lower index).
template <typename Accel>
inline void TestQuad(const Accel& q, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                     Candidate* best) {
  const double denom = q.normal.dot(d);
  if (!(std::abs(denom) > 1e-12)) return;  // parallel to the plane (or NaN)
  const double t = q.normal.dot(q.origin - o) / denom;
  if (!(t > t_min) || t > best->t) return;
  // Ties go to the lower index; with no hit yet (index -1) a distance of exactly max_distance is excluded.
  if (t == best->t && q.index > best->index) return;
  const Eigen::Vector3d rel = o + t * d - q.origin;
  const double a = rel.dot(q.dual_u);
  if (a < -kEdgeEps || a > 1.0 + kEdgeEps) return;
  const double b = rel.dot(q.dual_v);
  if (b < -kEdgeEps || b > 1.0 + kEdgeEps) return;
  best->t = t;
  best->index = q.index;
  best->accel = &q;
  best->a = a;
  best->b = b;
  best->denom = denom;
}

// Double slab test of the ray segment (t_min, t_max) against a box (NaN-free inverse).
bool SlabHit(const Eigen::Vector3d& box_min, const Eigen::Vector3d& box_max, const Eigen::Vector3d& o,
             const Eigen::Vector3d& d, double t_min, double t_max) {
  for (int i = 0; i < 3; ++i) {
    const double inv = std::abs(d[i]) < 1e-20 ? std::copysign(1e30, d[i]) : 1.0 / d[i];
    const double ta = (box_min[i] - o[i]) * inv, tb = (box_max[i] - o[i]) * inv;
    t_min = std::max(t_min, std::min(ta, tb));
    t_max = std::min(t_max, std::max(ta, tb));
  }
  return t_min <= t_max;
}

template <typename Accel>
Hit MakeHit(const Candidate& c, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) {
  const Accel& q = *static_cast<const Accel*>(c.accel);
  Hit hit;
  hit.distance = c.t;
  hit.point = origin + c.t * direction;
  hit.normal = c.denom < 0.0 ? q.normal : Eigen::Vector3d(-q.normal);
  hit.u_m = std::clamp(c.a, 0.0, 1.0) * q.length_u;
  hit.v_m = std::clamp(c.b, 0.0, 1.0) * q.length_v;
  return hit;
}

// The hit of the nearest static quad found by a search, if any.
template <typename QuadAccel>
std::optional<Hit> StaticHitOf(const Candidate& best, const std::vector<Quad>& quads,
                               const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) {
  if (best.accel == nullptr) return std::nullopt;
  Hit hit = MakeHit<QuadAccel>(best, origin, direction);
  hit.quad = &quads[best.index];
  return hit;
}

}  // namespace

void Scene::IntersectMoving(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, int64_t t_ns,
                            double min_distance, std::optional<Hit>* best) const {
  for (int k = 0; k < static_cast<int>(moving_objects_.size()); ++k) {
    const MovingAccel& m = moving_accel_[k];
    if (m.quads.empty()) continue;
    const double t_max = best->has_value() ? (*best)->distance : std::numeric_limits<double>::infinity();
    if (!SlabHit(m.swept_min, m.swept_max, origin, direction, min_distance, t_max)) continue;
    const Rigid3d world_from_object = moving_objects_[k].WorldFromObject(t_ns);
    const Eigen::Matrix3d object_from_world_r = world_from_object.RotationMatrix().transpose();
    const Eigen::Vector3d o = object_from_world_r * (origin - world_from_object.translation);
    const Eigen::Vector3d d = object_from_world_r * direction;
    if (!SlabHit(m.box_min, m.box_max, o, d, min_distance, t_max)) continue;
    Candidate c;
    c.t = t_max;
    c.index = -1;
    for (const QuadAccel& q : m.quads) TestQuad(q, o, d, min_distance, &c);
    if (c.accel == nullptr) continue;
    // Moving geometry wins only when strictly nearer than what was found.
    if (best->has_value() && !(c.t < (*best)->distance)) continue;
    Hit hit = MakeHit<QuadAccel>(c, o, d);
    hit.point = origin + c.t * direction;
    hit.normal = world_from_object.rotation * hit.normal;
    hit.quad = &moving_objects_[k].quads_in_object[c.index];
    hit.moving_object = k;
    *best = hit;
  }
}

std::optional<Hit> Scene::Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                    int64_t t_ns, double min_distance, double max_distance) const {
  MCVO_CHECK_MSG(built_, "Scene::Build() must be called before Intersect");
  Candidate best;
  best.t = max_distance;
  if (!nodes_.empty()) {
    const float o[3] = {static_cast<float>(origin.x()), static_cast<float>(origin.y()),
                        static_cast<float>(origin.z())};
    const float inv[3] = {SafeInverse(direction.x()), SafeInverse(direction.y()), SafeInverse(direction.z())};
    const float t_lo = RoundDown(min_distance);
    // Conservative float slab test against a node; returns the entry distance or +inf on a miss.
    const auto slab = [&](const Node& node, float t_hi) {
      float t0 = t_lo, t1 = t_hi;
      for (int i = 0; i < 3; ++i) {
        const float ta = (node.box_min[i] - o[i]) * inv[i];
        const float tb = (node.box_max[i] - o[i]) * inv[i];
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
      }
      return t0 <= t1 ? t0 : std::numeric_limits<float>::infinity();
    };
    std::array<std::pair<int, float>, kStackSize> stack;
    int sp = 0;
    int node_index = 0;
    float t_hi = RoundUp(best.t);
    if (slab(nodes_[0], t_hi) != std::numeric_limits<float>::infinity()) {
      while (true) {
        const Node& node = nodes_[node_index];
        if (node.count > 0) {
          for (int i = node.first; i < node.first + node.count; ++i)
            TestQuad(accel_[i], origin, direction, min_distance, &best);
          t_hi = RoundUp(best.t);
        } else {
          const float tl = slab(nodes_[node.first], t_hi);
          const float tr = slab(nodes_[node.first + 1], t_hi);
          const bool hit_l = tl <= t_hi, hit_r = tr <= t_hi;
          if (hit_l && hit_r) {
            MCVO_CHECK(sp < kStackSize);
            if (tl <= tr) {
              stack[sp++] = {node.first + 1, tr};
              node_index = node.first;
            } else {
              stack[sp++] = {node.first, tl};
              node_index = node.first + 1;
            }
            continue;
          }
          if (hit_l || hit_r) {
            node_index = hit_l ? node.first : node.first + 1;
            continue;
          }
        }
        // Pop the next node still nearer than the best hit.
        while (sp > 0 && stack[sp - 1].second > t_hi) --sp;
        if (sp == 0) break;
        node_index = stack[--sp].first;
      }
    }
  }
  std::optional<Hit> result = StaticHitOf<QuadAccel>(best, quads_, origin, direction);
  IntersectMoving(origin, direction, t_ns, min_distance, &result);
  if (result && !(result->distance < max_distance)) result.reset();
  return result;
}

std::optional<Hit> Scene::IntersectBruteForce(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                              int64_t t_ns, double min_distance, double max_distance) const {
  MCVO_CHECK_MSG(built_, "Scene::Build() must be called before IntersectBruteForce");
  Candidate best;
  best.t = max_distance;
  for (const QuadAccel& q : accel_) TestQuad(q, origin, direction, min_distance, &best);
  std::optional<Hit> result = StaticHitOf<QuadAccel>(best, quads_, origin, direction);
  IntersectMoving(origin, direction, t_ns, min_distance, &result);
  if (result && !(result->distance < max_distance)) result.reset();
  return result;
}

}  // namespace mcvo::synth
