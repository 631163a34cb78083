// The synthetic 3-D world: textured rectangles ("quads") in a bounding volume
// hierarchy, plus a few rigid moving objects, intersected by rays. World
// frame: metres, z up, ground at z = 0.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"
#include "mcvo/synth/material.h"

namespace mcvo::synth {

// A rectangle {origin + a * axis_u + b * axis_v : a, b in [0, 1]}. axis_u and
// axis_v are orthogonal; their lengths are the rectangle's size in metres.
// Convention for builders: the front face normal axis_u x axis_v points to
// where the surface is meant to be seen from (intersection is two-sided
// anyway), and for vertical surfaces axis_v points up (+z).
struct Quad {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d axis_v = Eigen::Vector3d::UnitY();
  Material material = Material::kAsphalt;
  uint32_t texture_seed = 0;
};

// An axis-aligned (in its own frame) box made of up to 6 quads, used for
// buildings, furniture, cars. Builders create boxes through Scene::AddBox.
struct BoxSpec {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  // centre of the bottom face, world
  double yaw_rad = 0.0;                              // rotation about world z
  Eigen::Vector3d size = Eigen::Vector3d::Ones();    // length (x), width (y), height (z)
  Material side_material = Material::kMetal;         // the four vertical faces
  Material top_material = Material::kMetal;
  bool with_bottom = false;
  uint32_t texture_seed = 0;
};

// The faces of `box` as quads, in the order +x, +y, -x, -y (the sides, in the
// box's own frame before the yaw), top, bottom (when with_bottom). Face k gets
// the texture seed BoxFaceSeed(box.texture_seed, k), so two boxes with the
// same spec look the same.
std::vector<Quad> MakeBoxQuads(const BoxSpec& box);
uint32_t BoxFaceSeed(uint32_t box_seed, int face);

struct Hit {
  double distance = 0.0;  // along the unit ray direction, metres
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, facing the ray origin
  double u_m = 0.0;                                   // texture coordinates on the quad, metres
  double v_m = 0.0;
  const Quad* quad = nullptr;  // the quad hit (object frame for moving objects)
  int moving_object = -1;      // index into moving_objects(), -1 for static geometry
};

// A rigid object moving along a straight line at constant speed, looping
// (ping-pong) between two positions; its quads are in the object frame.
struct MovingObject {
  std::vector<Quad> quads_in_object;
  Eigen::Vector3d start_in_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d end_in_world = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
  double speed_mps = 5.0;

  Rigid3d WorldFromObject(int64_t t_ns) const;
};

class Scene {
 public:
  // Adds a quad; returns its index. Invalidates the acceleration structure
  // until Build() is called again.
  int AddQuad(const Quad& quad);
  // Adds the faces of a box as quads (axis_v up on the sides, outward normals).
  void AddBox(const BoxSpec& box);
  void AddMovingObject(MovingObject object);

  // Builds the BVH. Deterministic (same quads in the same order -> same tree).
  void Build();

  // Nearest intersection with distance in (min_distance, max_distance), or
  // nullopt. `direction` must be unit. Moving objects are placed at t_ns.
  // Thread-safe after Build().
  std::optional<Hit> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, int64_t t_ns,
                               double min_distance = 1e-4, double max_distance = 1e4) const;

  // Reference implementation for tests: the same ray-quad test over every
  // quad without the BVH. Gives exactly the result of Intersect (ties in
  // distance go to the lower quad index in both).
  std::optional<Hit> IntersectBruteForce(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                         int64_t t_ns, double min_distance = 1e-4,
                                         double max_distance = 1e4) const;

  int num_bvh_nodes() const { return static_cast<int>(nodes_.size()); }

  const std::vector<Quad>& quads() const { return quads_; }
  const std::vector<MovingObject>& moving_objects() const { return moving_objects_; }

 private:
  // Bounding-volume node. Boxes are stored in float, rounded outwards and
  // padded, so they always contain their quads (a conservative slab test).
  struct Node {
    float box_min[3];
    float box_max[3];
    int first = 0;  // leaf: first index into accel_; inner: index of the left child (right = left + 1)
    int count = 0;  // leaf: number of quads; inner: 0
  };
  // A quad prepared for the ray test: unit plane normal along axis_u x axis_v
  // and the dual axes axis_u / |axis_u|^2, axis_v / |axis_v|^2
  // that give the rectangle coordinates a, b in [0, 1] of a plane point.
  struct QuadAccel {
    Eigen::Vector3d origin;
    Eigen::Vector3d normal;
    Eigen::Vector3d dual_u;
    Eigen::Vector3d dual_v;
    double length_u = 0.0;
    double length_v = 0.0;
    int index = 0;  // into quads_ (or the moving object's quads_in_object)
  };
  struct MovingAccel {
    std::vector<QuadAccel> quads;
    Eigen::Vector3d box_min, box_max;      // object frame, padded
    Eigen::Vector3d swept_min, swept_max;  // world frame, over the whole path: a cheap first rejection
  };
  static QuadAccel MakeAccel(const Quad& quad, int index);
  void IntersectMoving(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, int64_t t_ns,
                       double min_distance, std::optional<Hit>* best) const;

  std::vector<Quad> quads_;
  std::vector<QuadAccel> accel_;  // in leaf order
  std::vector<Node> nodes_;
  std::vector<MovingObject> moving_objects_;
  std::vector<MovingAccel> moving_accel_;
  bool built_ = false;
};

// How the rig moves through a scene.
enum class MotionStyle {
  kVehicle,   // car-like: yaw from the path tangent, small pitch/roll, ~10 m/s
  kHandheld,  // walking person / hand-held rig: ~1.2 m/s, gentle sway and bob
};

// A scene with the route the rig drives through it.
struct SceneWithRoute {
  std::string name;
  Scene scene;                             // Build() already called
  std::vector<Eigen::Vector3d> waypoints;  // route centre line at ground level (z = 0), world
  bool route_closed = false;               // the route returns to its start
  MotionStyle style = MotionStyle::kVehicle;
  double speed_mps = 10.0;
  double rig_height_m = 1.2;  // height of the rig origin above the ground
  // Height of the ceiling over the whole route, 0 for open sky. Where there
  // is one, `mcvo synth` carries the rig by the centre of its cameras,
  // lowers a rig whose cameras would come closer to it than
  // kCeilingClearanceM and refuses one whose cameras reach within
  // kWallClearanceM of a wall (synthesize.cc, FitRigToRoom).
  double ceiling_height_m = 0.0;
};

// Least distance between a camera centre and the ceiling, or the floor, of
// a scene with a ceiling, anywhere on the route.
inline constexpr double kCeilingClearanceM = 0.3;
inline constexpr double kFloorClearanceM = 0.2;
// Least distance between a camera centre and a wall it would otherwise pass
// behind (along the line from the route's centre line to the camera).
inline constexpr double kWallClearanceM = 0.05;

// Scene builders. Deterministic for a seed.
// urban: a grid of streets with building facades on both sides,
//   intersections, turns; the route returns to an earlier place (loop):
//   a closed 1.2 km route with 6 left and 2 right turns.
// urban_block: the same city generator (facades, intersections, moving
//   cars) on a smaller grid; the route is a short closed lap around one
//   block (counter-clockwise, 4 left turns; rig path about 290-360 m, lap
//   about 53 s). Driven more than once (a sequence longer than the lap), it
//   revisits every place: the loop-closure test scene.
// urban_small_block: urban_block with blocks of 24-32 m (lap about 190 m,
//   37 s): the same revisit in two thirds of the frames, for quick checks
//   (the loop-closure CLI test).
// urban_repeated: a regular grid whose buildings all wear the same
//   kUrbanRepeatedFacadeTextures facade textures (and one shop-front
//   design; no posters, no trees), so many places look alike; the route is
//   open (a staircase of 5 blocks, 2 left and 2 right turns, rig path about
//   470-490 m) and never comes back near an earlier place: every match
//   between its frames at different places is a false loop.
// urban_small_repeated: urban_repeated with blocks of 36-40 m (rig path
//   about 250 m): look-alike blocks 75-120 m back, for quick checks.
// indoor: corridors and a lab, long textureless wall segments.
// open: sparse, distant structure on open terrain.
SceneWithRoute BuildUrbanScene(uint64_t seed);
SceneWithRoute BuildUrbanBlockScene(uint64_t seed);
SceneWithRoute BuildUrbanSmallBlockScene(uint64_t seed);
SceneWithRoute BuildUrbanRepeatedScene(uint64_t seed);
SceneWithRoute BuildUrbanSmallRepeatedScene(uint64_t seed);
SceneWithRoute BuildIndoorScene(uint64_t seed);
SceneWithRoute BuildOpenScene(uint64_t seed);
// Distinct (material, texture seed) pairs of the brick and plaster facades
// in urban_repeated (one plaster and one brick design).
inline constexpr int kUrbanRepeatedFacadeTextures = 2;
// The names BuildScene knows: urban, urban_block, urban_small_block,
// urban_repeated, urban_small_repeated, indoor, open.
const std::vector<std::string>& SceneNames();
// One of SceneNames(); throws InputError listing the names otherwise.
SceneWithRoute BuildScene(const std::string& name, uint64_t seed);

// Route statistics: length of the waypoint polyline (closing segment
// included when closed) and the number of left and right turns (direction
// changes of more than 30 degrees at a waypoint).
struct RouteStats {
  double length_m = 0.0;
  int left_turns = 0;
  int right_turns = 0;
};
RouteStats ComputeRouteStats(const SceneWithRoute& scene);

// One line per scene: quad and moving-object counts, quads per material,
// route length and turns.
std::string SceneSummary(const SceneWithRoute& scene);

// Ground-truth structure: a CSV file with a header line and one line per
// static quad: index, material name, origin xyz, axis_u xyz, axis_v xyz,
// texture seed. Numbers are written round-trip exact (FormatDouble);
// deterministic; written atomically. Throws InputError when not writable.
void WriteSceneCsv(const std::filesystem::path& path, const Scene& scene);

}  // namespace mcvo::synth
