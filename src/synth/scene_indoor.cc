// Indoor scene (MultiCamData-like): a ring of 2.4 m wide, 2.8 m high
// corridors around a block of offices, and a ~10 x 8 m lab opening off the
// north corridor through two wide doorways.
//
// Layout (metres, z up): corridor centre lines on the rectangle
// [0, W] x [0, H]; the lab spans [L0, L0 + 10] x [H + 1.2, H + 9.2]. Walls are
// nearly textureless paint with long plain stretches (>= 8 m) between doors,
// posters and notice boards. The route walks the corridor ring and detours
// through the lab (in through one doorway, across, out through the other).
#include <cmath>

#include "mcvo/synth/scene.h"
#include "scene_build_util.h"

namespace mcvo::synth {
namespace {

using Eigen::Vector2d;
using internal::SceneRng;

constexpr double kHalfWidth = 1.2;  // corridor half width
constexpr double kHeight = 2.8;
constexpr double kLabX = 10.0, kLabY = 8.0;
constexpr double kDoorwayHalf = 1.6;  // the lab's doorways are 3.2 m wide
constexpr double kMaxTile = 8.0;      // floor and ceiling pieces at most this long

class IndoorBuilder {
 public:
  explicit IndoorBuilder(uint64_t seed) : rng_(seed) {}

  SceneWithRoute Build() {
    w_ = rng_.Uniform(32.0, 40.0);
    h_ = rng_.Uniform(12.0, 16.0);
    l0_ = rng_.Uniform(8.0, w_ - 18.0);
    xa_ = l0_ + 2.5;
    xb_ = l0_ + 7.5;
    const double r = kHalfWidth, lab_y0 = h_ + r, lab_y1 = lab_y0 + kLabY;
    // Corridor walls: outer ring facing inwards, inner ring facing outwards.
    Wall({w_ + r, -r}, {-r, -r}, {0, 1}, true);
    Wall({w_ + r, h_ + r}, {w_ + r, -r}, {-1, 0}, true);
    Wall({-r, h_ + r}, {xa_ - kDoorwayHalf, h_ + r}, {0, -1}, true);
    Wall({xa_ + kDoorwayHalf, h_ + r}, {xb_ - kDoorwayHalf, h_ + r}, {0, -1}, false);
    Wall({xb_ + kDoorwayHalf, h_ + r}, {w_ + r, h_ + r}, {0, -1}, true);
    Wall({-r, -r}, {-r, h_ + r}, {1, 0}, true);
    Wall({r, r}, {w_ - r, r}, {0, 1}, true);
    Wall({w_ - r, r}, {w_ - r, h_ - r}, {-1, 0}, true);
    Wall({w_ - r, h_ - r}, {r, h_ - r}, {0, -1}, true);
    Wall({r, h_ - r}, {r, r}, {1, 0}, true);
    // The doorways are open up to the ceiling: a rig carried by hand may
    // have cameras above head height (synthesize.cc, FitRigToRoom).
    // Lab walls, facing into the lab (decorated with the furniture).
    Wall({l0_, lab_y1}, {l0_, lab_y0}, {1, 0}, false);
    Wall({l0_ + kLabX, lab_y0}, {l0_ + kLabX, lab_y1}, {-1, 0}, false);
    Wall({l0_ + kLabX, lab_y1}, {l0_, lab_y1}, {0, -1}, false);
    // Floors and ceilings.
    FloorAndCeiling(-r, -r, w_ + r, r);
    FloorAndCeiling(-r, h_ - r, w_ + r, h_ + r);
    FloorAndCeiling(-r, r, r, h_ - r);
    FloorAndCeiling(w_ - r, r, w_ + r, h_ - r);
    FloorAndCeiling(l0_, lab_y0, l0_ + kLabX, lab_y1);
    AddLabFurniture(lab_y0);

    result_.name = "indoor";
    result_.waypoints = {
        {0, 0, 0},    {w_, 0, 0}, {w_, h_, 0}, {xb_, h_, 0}, {xb_, lab_y0 + 4.0, 0}, {xa_, lab_y0 + 4.0, 0},
        {xa_, h_, 0}, {0, h_, 0}};
    result_.route_closed = true;
    result_.style = MotionStyle::kHandheld;
    result_.speed_mps = 1.2;
    result_.rig_height_m = 1.4;
    result_.ceiling_height_m = kHeight;
    result_.scene.Build();
    return std::move(result_);
  }

 private:
  Scene& scene() { return result_.scene; }

  // A painted wall from a to b (ground plane) facing `front`; decorated with
  // doors, posters and notice boards separated by long plain stretches.
  void Wall(const Vector2d& a, const Vector2d& b, const Vector2d& front, bool decorate) {
    AddFacing(a, b, front, 0.0, kHeight, 0.0, Material::kWallPaint);
    if (!decorate) return;
    const Vector2d dir = (b - a).normalized();
    const double length = (b - a).norm();
    // The first plain stretch is always long, so every decorated wall of
    // more than ~10 m has a plain segment of >= 8 m.
    double pos = rng_.Uniform(0.6, 2.0);
    bool long_gap = rng_.Bernoulli(0.5);
    if (long_gap) pos += rng_.Uniform(8.5, 10.5);
    while (true) {
      const double kind = rng_.Uniform(0.0, 1.0);
      const double item = kind < 0.45   ? rng_.Uniform(0.9, 1.0)
                          : kind < 0.75 ? rng_.Uniform(0.5, 0.7)
                                        : rng_.Uniform(1.2, 1.8);
      if (pos + item > length - 0.5) break;
      const Vector2d p0 = a + pos * dir, p1 = a + (pos + item) * dir;
      if (kind < 0.45) {
        AddFacing(p0, p1, front, 0.0, 2.05, 0.02, Material::kWood);  // door
      } else if (kind < 0.75) {
        AddFacing(p0, p1, front, rng_.Uniform(1.1, 1.4), rng_.Uniform(0.7, 1.0), 0.01, Material::kPoster);
      } else {  // notice board: a wooden board with a few sheets pinned on it
        const double z0 = rng_.Uniform(0.95, 1.1), height = rng_.Uniform(0.9, 1.1);
        AddFacing(p0, p1, front, z0, height, 0.015, Material::kWood);
        for (double at = 0.1; at + 0.3 < item - 0.05; at += rng_.Uniform(0.35, 0.5)) {
          const double sheet = rng_.Uniform(0.21, 0.3);
          AddFacing(p0 + at * dir, p0 + (at + sheet) * dir, front, z0 + rng_.Uniform(0.1, height - 0.5),
                    sheet * 1.41, 0.025, Material::kPoster);
        }
      }
      pos += item;
      pos += long_gap ? rng_.Uniform(1.5, 4.0) : rng_.Uniform(8.5, 10.5);
      long_gap = !long_gap;
    }
  }

  // A vertical quad from a to b, `offset` in front of the wall line, facing `front`.
  void AddFacing(const Vector2d& a, const Vector2d& b, const Vector2d& front, double z0, double height,
                 double offset, Material material) {
    const Vector2d d = b - a;
    const bool a_first = d.y() * front.x() - d.x() * front.y() > 0.0;  // right of a->b is the front
    const Vector2d o = offset * front;
    scene().AddQuad(internal::VerticalQuad((a_first ? a : b) + o, (a_first ? b : a) + o, z0, height, material,
                                           rng_.Seed32()));
  }

  void FloorAndCeiling(double x0, double y0, double x1, double y1) {
    const int nx = static_cast<int>(std::ceil((x1 - x0) / kMaxTile - 1e-9));
    const int ny = static_cast<int>(std::ceil((y1 - y0) / kMaxTile - 1e-9));
    for (int i = 0; i < nx; ++i) {
      for (int j = 0; j < ny; ++j) {
        const double ax = x0 + (x1 - x0) * i / nx, bx = x0 + (x1 - x0) * (i + 1) / nx;
        const double ay = y0 + (y1 - y0) * j / ny, by = y0 + (y1 - y0) * (j + 1) / ny;
        scene().AddQuad(internal::HorizontalQuad(ax, ay, bx, by, 0.0, Material::kFloorTile, rng_.Seed32()));
        scene().AddQuad(internal::HorizontalQuad(ax, ay, bx, by, kHeight, Material::kCeiling, rng_.Seed32(),
                                                 /*facing_down=*/true));
      }
    }
  }

  void Box(double x0, double y0, double x1, double y1, double z0, double height, Material side,
           Material top) {
    BoxSpec box;
    box.center = Eigen::Vector3d(0.5 * (x0 + x1), 0.5 * (y0 + y1), z0);
    box.size = Eigen::Vector3d(x1 - x0, y1 - y0, height);
    box.side_material = side;
    box.top_material = top;
    box.texture_seed = rng_.Seed32();
    scene().AddBox(box);
  }

  // Furniture keeps >= 1.5 m from the route (the lab legs at x = xa, xb and
  // the crossing at y = lab_y0 + 4).
  void AddLabFurniture(double lab_y0) {
    const double x = l0_, y = lab_y0;
    // Desks with monitors along the north wall, and an island desk.
    for (int k = 0; k < 5; ++k) {
      const double dx = x + 1.0 + 1.6 * k;
      Box(dx, y + 7.2, dx + 1.55, y + 8.0, 0.0, 0.75, Material::kWood, Material::kWood);
      if (rng_.Bernoulli(0.7)) {
        Box(dx + 0.4, y + 7.6, dx + 0.95, y + 7.66, 0.75, 0.38, Material::kMetal, Material::kMetal);
      }
    }
    Box(x + 3.5, y + 5.6, x + 6.5, y + 6.4, 0.0, 0.75, Material::kWood, Material::kWood);
    Box(x + 4.0, y + 6.05, x + 4.55, y + 6.11, 0.75, 0.38, Material::kMetal, Material::kMetal);
    // Cabinets along the west wall, a machine and a cabinet on the east wall,
    // a printer against the wall between the doorways.
    for (int k = 0; k < 3; ++k) {
      Box(x, y + 0.6 + 2.0 * k, x + 0.5, y + 1.6 + 2.0 * k, 0.0, rng_.Uniform(1.8, 2.1), Material::kMetal,
          Material::kMetal);
    }
    Box(x + 9.1, y + 1.0, x + 10.0, y + 2.6, 0.0, 1.6, Material::kMetal, Material::kMetal);
    Box(x + 9.5, y + 5.2, x + 10.0, y + 6.4, 0.0, 2.0, Material::kMetal, Material::kMetal);
    Box(x + 4.2, y + 0.3, x + 5.8, y + 1.2, 0.0, 1.1, Material::kMetal, Material::kMetal);
    // Posters and a notice board above the desks.
    AddFacing({x + 1.5, y + 8.0}, {x + 2.2, y + 8.0}, {0, -1}, 1.3, 0.9, 0.01, Material::kPoster);
    AddFacing({x + 5.0, y + 8.0}, {x + 6.6, y + 8.0}, {0, -1}, 1.1, 1.0, 0.015, Material::kWood);
    AddFacing({x + 5.2, y + 8.0}, {x + 5.5, y + 8.0}, {0, -1}, 1.3, 0.42, 0.025, Material::kPoster);
    AddFacing({x + 5.9, y + 8.0}, {x + 6.2, y + 8.0}, {0, -1}, 1.5, 0.42, 0.025, Material::kPoster);
  }

  SceneRng rng_;
  SceneWithRoute result_;
  double w_ = 0, h_ = 0, l0_ = 0, xa_ = 0, xb_ = 0;
};

}  // namespace

SceneWithRoute BuildIndoorScene(uint64_t seed) { return IndoorBuilder(seed).Build(); }

}  // namespace mcvo::synth
