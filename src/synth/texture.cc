// ShadeSurface / ShadeSky: input sanitising, dispatch to the per-material
// functions (texture_urban.cc, texture_ground.cc, texture_indoor.cc), the
// shared brick/slab/tile bond pattern, and the sky.
//
// Band-limiting, the rule every material follows: a texture is a sum and
// composite of components whose spatial frequency is known, and each is
// box-filtered over the footprint f in closed form:
//  - noise octaves of wavelength lambda (noise::Fbm) are weighted by
//    smoothstep(1, 2, lambda / f) and skipped at weight 0 (replaced by their
//    mean, 0), so nothing finer than the footprint is point-sampled;
//  - periodic or single steps (joints, window grids, stripes, markings) use
//    the exact integral of the pulse train over the footprint interval
//    (noise::PulseAverage), separable shapes as products of the per-axis
//    averages, nested rectangles by inclusion-exclusion;
//  - per-cell random values (brick tones, window contents) blend the cells
//    the footprint overlaps and fade to their mean once f nears the cell;
//  - level sets of noise (patches, leaves, blobs) and isolated dots use an
//    edge ramp of width f that fades into the expected coverage.
// Every weight is a continuous function of (u, v, f), so the texture is
// continuous in position and footprint: no flicker, no popping.
#include <algorithm>
#include <cmath>

#include "mcvo/synth/material.h"
#include "noise.h"
#include "texture_internal.h"

namespace mcvo::synth {
namespace texture {

double JointCoverage(const Bond& bond, double u, double v, double f) {
  // Interior coverage = sum over row parity p of
  //   [v in a row of parity p, above its bed joint] x [u not in that row's head joints],
  // both factors box-filtered per axis (the square filter is separable and
  // the rows of one parity share the same head-joint train).
  const double h = bond.height;
  const double m = bond.joint;
  double interior = 0.0;
  for (int parity = 0; parity < 2; ++parity) {
    const double in_rows = noise::PulseAverage(v, f, 2.0 * h, h - m, parity * h + m);
    const double between_heads =
        1.0 - noise::PulseAverage(u, f, bond.length, m, parity * bond.bond * bond.length);
    interior += in_rows * between_heads;
  }
  return 1.0 - interior;
}

double UnitTone(const Bond& bond, double u, double v, double f, uint32_t seed) {
  const double unit = std::min(bond.length, bond.height);
  const double fade = 1.0 - noise::Smoothstep(0.5 * unit, unit, f);
  if (fade <= 0.0) return 0.0;
  const noise::CellSpan rows = noise::SpanCells(v, f, bond.height, 0.0);
  double tone = 0.0;
  for (int dr = 0; dr < 2; ++dr) {
    const double wr = dr == 0 ? rows.w0 : 1.0 - rows.w0;
    if (wr <= 0.0) continue;
    const int64_t row = rows.cell + dr;
    const double offset = (row % 2 != 0) ? bond.bond * bond.length : 0.0;
    const noise::CellSpan cells = noise::SpanCells(u, f, bond.length, offset);
    for (int dc = 0; dc < 2; ++dc) {
      const double wc = dc == 0 ? cells.w0 : 1.0 - cells.w0;
      if (wc <= 0.0) continue;
      tone += wr * wc * (2.0 * noise::Unit(noise::HashLattice(cells.cell + dc, row, seed)) - 1.0);
    }
  }
  return fade * tone;
}

double SparseDots(double u, double v, double f, double period, double probability, double r_min, double r_max,
                  uint32_t seed) {
  // A cell's dot lies within 0.25 period + r of its centre, so the footprint
  // of the query (inside this cell) can touch no other dot while
  // f / 2 + r_max <= 0.25 period, i.e. f <= 0.4 period.
  const double mean_r2 = (r_min * r_min + r_min * r_max + r_max * r_max) / 3.0;
  const double mean = probability * 3.14159265358979 * mean_r2 / (period * period);
  const double fade = noise::Smoothstep(0.15 * period, 0.35 * period, f);
  if (fade >= 1.0) return mean;
  const int64_t cu = noise::FloorToInt(u / period);
  const int64_t cv = noise::FloorToInt(v / period);
  const uint32_t h = noise::HashLattice(cu, cv, seed);
  double dot = 0.0;
  if (noise::Unit(h) < probability) {
    const uint32_t h2 = noise::Mix(h);
    const double x = (static_cast<double>(cu) + 0.25 + 0.5 * noise::Unit(h2)) * period;
    const double y = (static_cast<double>(cv) + 0.25 + 0.5 * noise::Unit(noise::Mix(h2))) * period;
    const double r = r_min + (r_max - r_min) * noise::Unit(noise::Mix(h2 + 1));
    dot = noise::DotCoverage(u - x, v - y, r, f);
  }
  return noise::Lerp(dot, mean, fade);
}

}  // namespace texture

namespace {

double Sanitise(double x, double limit, double fallback) {
  if (!std::isfinite(x)) return fallback;
  return std::min(limit, std::max(-limit, x));
}

}  // namespace

float ShadeSurface(Material material, uint32_t seed, double u_m, double v_m, double footprint_m,
                   double extent_u_m, double extent_v_m) {
  texture::Query q{};
  q.u = Sanitise(u_m, 1e8, 0.0);
  q.v = Sanitise(v_m, 1e8, 0.0);
  q.f = std::isfinite(footprint_m) ? std::min(1e4, std::max(0.0, footprint_m)) : 0.0;
  q.extent_u = std::isfinite(extent_u_m) ? std::min(1e6, std::max(1e-3, extent_u_m)) : 1.0;
  q.extent_v = std::isfinite(extent_v_m) ? std::min(1e6, std::max(1e-3, extent_v_m)) : 1.0;
  q.seed = seed;
  double albedo = 0.5;
  switch (material) {
    case Material::kSky:
      albedo = ShadeSky(0.0, 0.0, 1.0);
      break;
    case Material::kAsphalt:
      albedo = texture::Asphalt(q);
      break;
    case Material::kRoadMarking:
      albedo = texture::RoadMarking(q);
      break;
    case Material::kSidewalk:
      albedo = texture::Sidewalk(q);
      break;
    case Material::kFacadePlaster:
      albedo = texture::FacadePlaster(q);
      break;
    case Material::kFacadeBrick:
      albedo = texture::FacadeBrick(q);
      break;
    case Material::kShopFront:
      albedo = texture::ShopFront(q);
      break;
    case Material::kPoster:
      albedo = texture::Poster(q);
      break;
    case Material::kWallPaint:
      albedo = texture::WallPaint(q);
      break;
    case Material::kFloorTile:
      albedo = texture::FloorTile(q);
      break;
    case Material::kCeiling:
      albedo = texture::Ceiling(q);
      break;
    case Material::kWood:
      albedo = texture::Wood(q);
      break;
    case Material::kMetal:
      albedo = texture::Metal(q);
      break;
    case Material::kGrass:
      albedo = texture::Grass(q);
      break;
    case Material::kRock:
      albedo = texture::Rock(q);
      break;
    case Material::kFoliage:
      albedo = texture::Foliage(q);
      break;
    case Material::kMarker:
      albedo = texture::Marker(q);
      break;
  }
  if (!(albedo == albedo)) albedo = 0.5;  // NaN cannot happen by construction; never return one
  return static_cast<float>(std::min(0.98, std::max(0.02, albedo)));
}

float ShadeSky(double dx, double dy, double dz) {
  const double norm = std::sqrt(dx * dx + dy * dy + dz * dz);
  if (!std::isfinite(norm) || norm <= 0.0) return 0.7f;
  const double z = dz / norm;
  // Gradient: 0.92 at the horizon down to 0.62 at the zenith.
  const double t = 1.0 - std::max(0.0, z);
  double sky = 0.62 + 0.30 * (t * t) * (t * t);
  if (z > 0.02) {
    // Clouds on a plane 1 km up: low-frequency noise, soft threshold, +0.06 at
    // most, faded out towards the horizon where the plane's texture would
    // compress into high angular frequencies.
    const double scale = 1000.0 / dz;
    const double n = noise::Fbm(dx * scale, dy * scale, 0.0, 0x5eedc10dU, 1500.0, 180.0, 0.5);
    const double cloud = noise::Smoothstep(-0.3, 1.2, n);
    sky += 0.06 * cloud * noise::Smoothstep(0.02, 0.25, z);
  }
  // Below the horizon: a dim constant, with a short smooth transition.
  const double ground = 0.18;
  const double value = noise::Lerp(ground, sky, noise::Smoothstep(-0.03, 0.0, z));
  return static_cast<float>(std::min(0.98, std::max(0.02, value)));
}

}  // namespace mcvo::synth
