// The synthetic 3-D world: textured rectangles ("quads") in a bounding volume
// hierarchy, plus a few rigid moving objects, intersected by rays. World
// frame: metres, z up, ground at z = 0.
#pragma once

#include <cstdint>
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

struct Hit {
  double distance = 0.0;  // along the unit ray direction, metres
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, facing the ray origin
  double u_m = 0.0;  // texture coordinates on the quad, metres
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
  std::optional<Hit> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                               int64_t t_ns, double min_distance = 1e-4, double max_distance = 1e4) const;

  const std::vector<Quad>& quads() const { return quads_; }
  const std::vector<MovingObject>& moving_objects() const { return moving_objects_; }

 private:
  struct Node {
    Eigen::Vector3d box_min, box_max;
    int first = 0;   // leaf: first index into order_; inner: index of the left child
    int count = 0;   // leaf: number of quads; inner: 0
  };
  std::vector<Quad> quads_;
  std::vector<int> order_;  // quad indices in leaf order
  std::vector<Node> nodes_;
  std::vector<MovingObject> moving_objects_;
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
  Scene scene;                                // Build() already called
  std::vector<Eigen::Vector3d> waypoints;     // route centre line at ground level (z = 0), world
  bool route_closed = false;                  // the route returns to its start
  MotionStyle style = MotionStyle::kVehicle;
  double speed_mps = 10.0;
  double rig_height_m = 1.2;                  // height of the rig origin above the ground
};

// Scene builders. Deterministic for a seed.
// urban: a grid of streets with building facades on both sides,
//   intersections, turns; the route returns to an earlier place (loop).
// indoor: corridors and a lab, long textureless wall segments.
// open: sparse, distant structure on open terrain.
SceneWithRoute BuildUrbanScene(uint64_t seed);
SceneWithRoute BuildIndoorScene(uint64_t seed);
SceneWithRoute BuildOpenScene(uint64_t seed);
// "urban", "indoor", "open"; throws InputError listing the names otherwise.
SceneWithRoute BuildScene(const std::string& name, uint64_t seed);

}  // namespace mcvo::synth
