// Per-material shading functions behind ShadeSurface (private to src/synth).
// Each returns the box-filtered albedo over the footprint, before the final
// clamp to [0.02, 0.98] done by ShadeSurface.
#pragma once

#include <cstdint>

namespace mcvo::synth::texture {

// One shading query: texture coordinates (metres, sanitised: finite,
// |u|, |v| <= 1e8), footprint side f >= 0, quad extents > 0, surface seed.
struct Query {
  double u;
  double v;
  double f;
  double extent_u;
  double extent_v;
  uint32_t seed;
};

// texture_urban.cc: buildings.
double FacadePlaster(const Query& q);
double FacadeBrick(const Query& q);
double ShopFront(const Query& q);
double Poster(const Query& q);

// texture_ground.cc: roads and terrain.
double Asphalt(const Query& q);
double RoadMarking(const Query& q);
double Sidewalk(const Query& q);
double Grass(const Query& q);
double Rock(const Query& q);
double Foliage(const Query& q);

// texture_indoor.cc: interiors and objects.
double WallPaint(const Query& q);
double FloorTile(const Query& q);
double Ceiling(const Query& q);
double Wood(const Query& q);
double Metal(const Query& q);
double Marker(const Query& q);

// Shared pattern: a running-bond (or stack-bond) grid of units of pitch
// `length` x `height` separated by joints of width `joint` (bricks, slabs,
// tiles, planks). Row r spans v in [r height, (r + 1) height) and is shifted
// by `bond` * length * (r mod 2) along u; the bed joint is at the bottom of
// each row and the head joint at the left of each unit.
struct Bond {
  double length;
  double height;
  double joint;
  double bond;  // 0: stack bond, 0.5: running bond
};

// Box-filtered fraction of the footprint covered by joints (exact).
double JointCoverage(const Bond& bond, double u, double v, double f);

// Per-unit random tone in [-1, 1] (uniform), blended over the (at most 2 x 2)
// units the footprint overlaps and faded to 0 as f approaches the unit size.
double UnitTone(const Bond& bond, double u, double v, double f, uint32_t seed);

// Sparse dots: in each cell of side `period`, with probability `probability`,
// a disc of radius in [r_min, r_max] (r_max <= 0.05 period) centred in the
// middle half of the cell. Box-filtered coverage (DotCoverage), fading to the
// mean coverage once the footprint could reach a neighbouring cell's dot.
double SparseDots(double u, double v, double f, double period, double probability, double r_min, double r_max,
                  uint32_t seed);

}  // namespace mcvo::synth::texture
