// Indoor and object materials: wall paint, floor tiles, ceiling panels,
// wood, metal, and the marker disc. See texture.cc for the band-limiting rule.
#include <algorithm>
#include <cmath>

#include "noise.h"
#include "texture_internal.h"

namespace mcvo::synth::texture {

using noise::Draw;
using noise::Fbm;
using noise::Lerp;
using noise::SubSeed;

// Nearly textureless paint: the weak-texture case. Only wavelengths of
// 0.375 m and longer, std 0.008 in albedo (about 2 grey levels at 8 bits
// before lighting): corners must be hard to find and LK poorly conditioned.
double WallPaint(const Query& q) {
  const double base = Draw(q.seed, 0, 0.55, 0.75);
  return base + 0.008 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 1), 3.0, 0.35, 0.6);
}

// Square tiles (30-60 cm) with 3-6 mm grout, optionally a checkerboard of two
// tones, speckled (terrazzo-like fine noise), with low-frequency dirt.
double FloorTile(const Query& q) {
  const double sizes[4] = {0.3, 0.4, 0.5, 0.6};
  const double size = sizes[std::min(3, static_cast<int>(Draw(q.seed, 0, 0.0, 4.0)))];
  const Bond bond{size, size, Draw(q.seed, 1, 0.003, 0.006), Draw(q.seed, 2) < 0.25 ? 0.5 : 0.0};
  const double base = Draw(q.seed, 3, 0.35, 0.7);
  double tile = base + 0.035 * UnitTone(bond, q.u, q.v, q.f, SubSeed(q.seed, 4));
  if (Draw(q.seed, 5) < 0.3) {
    // Checkerboard: [even column] XOR [even row]; the box filter of the
    // separable product is the product of the per-axis averages (exact).
    const double a = noise::PulseAverage(q.u, q.f, 2.0 * size, size, 0.0);
    const double b = noise::PulseAverage(q.v, q.f, 2.0 * size, size, 0.0);
    const double same = a * b + (1.0 - a) * (1.0 - b);
    tile += Lerp(-0.2, 0.2, same);
  }
  tile += 0.03 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 6), 0.03, 0.001, 0.75);
  const double grout = Draw(q.seed, 7) < 0.5 ? 0.2 : 0.75;
  const double joints = JointCoverage(bond, q.u, q.v, q.f);
  const double dirt = 0.04 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 8), 2.0, 0.1, 0.5);
  return Lerp(tile, grout, joints) + dirt;
}

// Suspended ceiling: 60 cm panels (fissured mineral fibre) on a 24 mm T-bar
// grid, with a louvred light fixture every few panels.
double Ceiling(const Query& q) {
  const double length = Draw(q.seed, 0) < 0.5 ? 0.6 : 1.2;
  const Bond bond{length, 0.6, 0.024, 0.0};
  const double panel = 0.78 + 0.02 * UnitTone(bond, q.u, q.v, q.f, SubSeed(q.seed, 1)) +
                       0.03 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 2), 0.02, 0.001, 0.8);
  const double tbar = Draw(q.seed, 3) < 0.6 ? 0.92 : 0.5;
  double value = Lerp(panel, tbar, JointCoverage(bond, q.u, q.v, q.f));
  // Fixtures fill the interior of one panel in every period_u x period_v.
  const double period_u = length * static_cast<double>(2 + static_cast<int>(Draw(q.seed, 4, 0.0, 3.0)));
  const double period_v = 0.6 * static_cast<double>(2 + static_cast<int>(Draw(q.seed, 5, 0.0, 3.0)));
  const double in_u = noise::PulseAverage(q.u, q.f, period_u, length - 0.024, 0.024);
  const double in_v = noise::PulseAverage(q.v, q.f, period_v, 0.6 - 0.024, 0.024);
  const double fixture = in_u * in_v;
  if (fixture > 0.0) {
    // Louvres: a grid of thin dark blades, period 1/4 panel.
    const double lu = noise::PulseAverage(q.u, q.f, 0.15, 0.008, 0.024);
    const double lv = noise::PulseAverage(q.v, q.f, 0.15, 0.008, 0.024);
    const double louvre = 1.0 - (1.0 - lu) * (1.0 - lv);
    value = Lerp(value, 0.97 - 0.45 * louvre, fixture);
  }
  return value;
}

// Planks (running bond, 2.5 mm joints) with per-plank tone, grain elongated
// along u and growth rings (a warped sinusoid, attenuated as its wavelength
// nears the footprint: the box filter of a sinusoid only scales it).
double Wood(const Query& q) {
  const Bond bond{Draw(q.seed, 0, 0.8, 2.4), Draw(q.seed, 1, 0.09, 0.2), 0.0025, Draw(q.seed, 2, 0.3, 0.7)};
  const double base = Draw(q.seed, 3, 0.3, 0.5);
  const double plank = UnitTone(bond, q.u, q.v, q.f, SubSeed(q.seed, 4));
  double value = base + 0.06 * plank;
  value += 0.05 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 5), 0.06, 0.0008, 0.7, 10.0);
  const double ring_wavelength = Draw(q.seed, 6, 0.008, 0.025);
  const double ring_weight = noise::OctaveWeight(ring_wavelength, 1.5 * q.f);
  if (ring_weight > 0.0) {
    const double warp = Fbm(q.u, q.v, 0.0, SubSeed(q.seed, 7), 0.25, 0.06, 0.5, 8.0);
    const double phase = (q.v + 0.06 * warp) / ring_wavelength + 3.0 * plank;
    value += 0.07 * ring_weight * std::sin(6.283185307179586 * phase);
  }
  return Lerp(value, 0.4 * base, JointCoverage(bond, q.u, q.v, q.f));
}

// Brushed metal panels: fine streaks along u, soft low-frequency sheen,
// dark seams, and a rivet 3 cm in from each panel corner.
double Metal(const Query& q) {
  const Bond bond{Draw(q.seed, 0, 1.0, 2.0), Draw(q.seed, 1, 0.6, 1.5), 0.003, 0.0};
  double value = Draw(q.seed, 2, 0.4, 0.65) + 0.04 * UnitTone(bond, q.u, q.v, q.f, SubSeed(q.seed, 3));
  value += 0.04 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 4), 0.01, 0.0004, 0.8, 30.0);
  value += 0.05 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 5), 3.0, 0.3, 0.5);
  value = Lerp(value, 0.1, JointCoverage(bond, q.u, q.v, q.f));
  // Rivets: nearest of the two rivet columns/rows of the panel. The
  // nearest-choice switches at least `inset` away from any rivet, so the dot
  // is exact while f/2 + r < inset and fades to its mean before that fails.
  const double inset = 0.03;
  const double radius = 0.005;
  const double fade = noise::Smoothstep(0.4 * inset, 0.8 * inset, q.f);
  const double mean = 4.0 * 3.14159265358979 * radius * radius / (bond.length * bond.height);
  double rivet = mean;
  if (fade < 1.0) {
    const auto nearest = [&](double x, double period) {
      const double r = x - std::floor(x / period) * period;
      return r < 0.5 * period ? r - inset : r - (period - inset);
    };
    const double dot = noise::DotCoverage(nearest(q.u, bond.length), nearest(q.v, bond.height), radius, q.f);
    rivet = Lerp(dot, mean, fade);
  }
  return Lerp(value, 0.8, rivet);
}

// Test target: white disc (albedo 0.95) of radius 0.35 x the shorter side,
// centred on the quad, on black (0.02). The edge is box-filtered
// symmetrically (DotCoverage), so the coverage centroid is the centre.
double Marker(const Query& q) {
  const double radius = 0.35 * std::min(q.extent_u, q.extent_v);
  const double coverage = noise::DotCoverage(q.u - 0.5 * q.extent_u, q.v - 0.5 * q.extent_v, radius, q.f);
  return 0.02 + 0.93 * coverage;
}

}  // namespace mcvo::synth::texture
