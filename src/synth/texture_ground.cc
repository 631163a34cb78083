// Ground and terrain materials: asphalt, road markings, sidewalk slabs,
// grass, rock, foliage. See texture.cc for the band-limiting rule.
#include <algorithm>
#include <cmath>

#include "noise.h"
#include "texture_internal.h"

namespace mcvo::synth::texture {
namespace {

using noise::Draw;
using noise::Fbm;
using noise::IntervalAverage;
using noise::Lerp;
using noise::SubSeed;

// Thin dark cracks along the zero set of a noise field of wavelength
// `lambda`: a band of `width` around the level set (distance from the
// linearised noise), masked to part of the surface, fading to its mean
// (zero-set length per area ~ 1.2 / lambda, times width) at coarse footprints.
double Cracks(const Query& q, double lambda, double width, uint32_t seed) {
  const double mask =
      noise::Smoothstep(0.2, 0.9, noise::GradientNoise(q.u / (4.0 * lambda), q.v / (4.0 * lambda), seed + 1));
  if (mask <= 0.0) return 0.0;
  const double mean = 1.2 * width / lambda;
  const double fade = noise::Smoothstep(0.1 * lambda, 0.3 * lambda, q.f);
  if (fade >= 1.0) return mask * mean;
  // Two octaves make the crack wiggle; distance = |n| / |grad n| with the
  // gradient from forward differences (floored, so saddles do not smear).
  const auto field = [&](double x, double y) {
    return noise::GradientNoise(x, y, seed) +
           0.45 * noise::GradientNoise(2.3 * x + 1.7, 2.3 * y + 4.1, seed + 7);
  };
  const double x = q.u / lambda;
  const double y = q.v / lambda;
  const double n = field(x, y);
  constexpr double kStep = 1e-3;
  const double gx = (field(x + kStep, y) - n) / kStep;
  const double gy = (field(x, y + kStep) - n) / kStep;
  const double slope = std::max(1.5, std::sqrt(gx * gx + gy * gy)) / lambda;
  const double line = noise::BandCoverage(std::abs(n) / slope, width, q.f);
  return mask * Lerp(line, mean, fade);
}

// Coverage of the region above `t` of a noise octave of wavelength lambda,
// skipping the noise evaluation once only the mean remains.
double Blobs(const Query& q, double lambda, double t, uint32_t seed, double* noise_value = nullptr) {
  const double mean = noise::TailProbability(t);
  if (q.f >= 0.8 * lambda && noise_value == nullptr) return mean;
  const double n = noise::GradientNoise(q.u / lambda, q.v / lambda, seed);
  if (noise_value != nullptr) *noise_value = n;
  return noise::ThresholdCoverage(n, t, lambda, q.f, mean);
}

}  // namespace

// Asphalt: multi-scale noise, octave gain 0.8 (2-D power spectrum
// ~ 1/f^(2 + 2 log2(1 / 0.8)) = 1/f^2.6; natural images ~ 1/f^2), bright aggregate
// stones and dark pores at the 6 mm scale, repair patches, cracks.
double Asphalt(const Query& q) {
  double value = Draw(q.seed, 0, 0.2, 0.32);
  value += 0.07 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 1), 6.0, 0.0015, 0.8);
  const double stones = Blobs(q, 0.006, 1.2, SubSeed(q.seed, 2));
  const double pores = Blobs(q, 0.005, 1.4, SubSeed(q.seed, 3));
  value += 0.12 * stones - 0.06 * pores;
  const double patch_noise = Fbm(q.u, q.v, q.f, SubSeed(q.seed, 4), 8.0, 2.0, 0.5);
  const double patch = noise::ThresholdCoverage(patch_noise, 1.2, 2.0, q.f, noise::TailProbability(1.2));
  value += Draw(q.seed, 5) < 0.5 ? -0.05 * patch : 0.04 * patch;
  value -= 0.12 * Cracks(q, 1.5, 0.005, SubSeed(q.seed, 6));
  return value;
}

// Markings on asphalt, laid out along the quad's longer side ("along"):
// a quad narrower than 1 m across is a lane line (0.15 m wide, or the quad's
// width if narrower, centred): solid, dashed (3 m dash, 6 m gap) or, when
// at least 0.35 m wide, a double line; a wider quad is a zebra crossing with
// stripes periodic along the longer side spanning the shorter side.
double RoadMarking(const Query& q) {
  const double asphalt = Asphalt(q);
  const bool along_u = q.extent_u >= q.extent_v;
  const double a = along_u ? q.u : q.v;
  const double b = along_u ? q.v : q.u;
  const double length = along_u ? q.extent_u : q.extent_v;
  const double across = along_u ? q.extent_v : q.extent_u;
  double cover = 0.0;
  if (across < 1.0) {
    const double style = Draw(q.seed, 10);
    const double c = 0.5 * across;
    double lateral = 0.0;
    if (style >= 0.8 && across >= 0.35) {
      lateral = IntervalAverage(b, q.f, c - 0.15, c - 0.05) + IntervalAverage(b, q.f, c + 0.05, c + 0.15);
    } else {
      const double w = std::min(0.15, across);
      lateral = IntervalAverage(b, q.f, c - 0.5 * w, c + 0.5 * w);
    }
    const double longitudinal = (style >= 0.4 && style < 0.8)
                                    ? noise::PulseAverageClipped(a, q.f, 9.0, 3.0, 0.5, 0.0, length)
                                    : IntervalAverage(a, q.f, 0.0, length);
    cover = lateral * longitudinal;
  } else {
    const double pitch = Draw(q.seed, 11, 0.9, 1.2);
    const double stripe = 0.5 * pitch;
    const int count = std::max(1, static_cast<int>((length - 0.2 + pitch - stripe) / pitch));
    const double start = 0.5 * (length - ((count - 1) * pitch + stripe));
    cover = noise::PulseAverageClipped(a, q.f, pitch, stripe, start, start,
                                       start + (count - 1) * pitch + stripe) *
            IntervalAverage(b, q.f, 0.05, across - 0.05);
  }
  if (cover <= 0.0) return asphalt;
  // Worn paint: the asphalt's grain shows through where the wear noise is high.
  const double wear = noise::Smoothstep(0.8, 2.5, Fbm(q.u, q.v, q.f, SubSeed(q.seed, 12), 0.8, 0.01, 0.6));
  return Lerp(asphalt, Lerp(0.86, asphalt + 0.15, 0.7 * wear), cover);
}

// Paving slabs with dark joints, per-slab tone, grain, stains, chewing-gum spots.
double Sidewalk(const Query& q) {
  const double size = Draw(q.seed, 0, 0.3, 0.6);
  const bool running = Draw(q.seed, 1) < 0.3;
  const Bond bond{running ? 2.0 * size : size, size, 0.006, running ? 0.5 : 0.0};
  double slab = Draw(q.seed, 2, 0.45, 0.62) + 0.05 * UnitTone(bond, q.u, q.v, q.f, SubSeed(q.seed, 3));
  slab += 0.04 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 4), 0.1, 0.001, 0.7);
  double value = Lerp(slab, 0.22, JointCoverage(bond, q.u, q.v, q.f));
  value += 0.05 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 5), 4.0, 0.1, 0.5);
  const double gum = SparseDots(q.u, q.v, q.f, 0.4, 0.35, 0.006, 0.015, SubSeed(q.seed, 6));
  return Lerp(value, 0.15, gum);
}

// Grass: multi-scale noise with a natural spectrum (octave gain 0.8: 2-D
// power ~ 1/f^2.6, 3 m down to 1 mm), blade glints and shadows at 8 mm, rare
// bare-soil patches.
double Grass(const Query& q) {
  double value = Draw(q.seed, 0, 0.28, 0.38) + 0.09 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 1), 3.0, 0.001, 0.8);
  const double mean = noise::TailProbability(1.2);
  if (q.f < 0.8 * 0.008) {
    double n = 0.0;
    Blobs(q, 0.008, 1.2, SubSeed(q.seed, 2), &n);
    value += 0.12 * noise::ThresholdCoverage(n, 1.2, 0.008, q.f, mean) -
             0.12 * noise::ThresholdCoverage(-n, 1.2, 0.008, q.f, mean);
  }
  const double soil = Fbm(q.u, q.v, q.f, SubSeed(q.seed, 3), 8.0, 1.5, 0.5);
  const double bare = noise::ThresholdCoverage(soil, 1.5, 1.5, q.f, noise::TailProbability(1.5));
  if (bare <= 0.0) return value;
  return Lerp(value, 0.3 + 0.05 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 4), 0.05, 0.002, 0.6), bare);
}

// Rock: rough multi-scale noise (octave gain 0.7: 2-D power ~ 1/f^3), cracks at two scales, pale
// lichen spots.
double Rock(const Query& q) {
  double value = Draw(q.seed, 0, 0.35, 0.5) + 0.09 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 1), 8.0, 0.001, 0.7);
  // Ridged octaves (0.6 m to 2 cm): creases like fractured facets. The
  // softened |n| has mean ~0.8 for unit-std noise; a faded octave keeps it.
  double lambda = 0.6;
  double amplitude = 0.06;
  for (uint32_t k = 0; k < 5; ++k, lambda *= 0.45, amplitude *= 0.6) {
    const double w = noise::OctaveWeight(lambda, q.f);
    if (w <= 0.0) break;
    const double n = noise::GradientNoise(q.u / lambda + 3.7 * k, q.v / lambda, SubSeed(q.seed, 10 + k));
    value += w * amplitude * (std::sqrt(n * n + 0.02) - 0.8);
  }
  value -= 0.2 * Cracks(q, 0.6, 0.01, SubSeed(q.seed, 2));
  value -= 0.2 * Cracks(q, 2.5, 0.02, SubSeed(q.seed, 3));
  return Lerp(value, 0.8, SparseDots(q.u, q.v, q.f, 0.25, 0.25, 0.005, 0.0125, SubSeed(q.seed, 4)));
}

// Foliage: two layers of leaves (level sets of noise at leaf size and half
// of it) over dark gaps, shaded by clumps; high contrast at the leaf scale.
double Foliage(const Query& q) {
  const double leaf = Draw(q.seed, 0, 0.07, 0.12);
  const double clump = 0.1 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 1), 1.5, 0.2, 0.5);
  double value = 0.05;
  double n = 0.0;
  // Inside a leaf the same noise shades it (brighter towards its middle);
  // that shading is a detail of the leaf's wavelength, weighted like an octave.
  // A faded shading keeps its mean over the leaf, E[clamp(n) | n > t]
  // (measured for GradientNoise: 0.507 for t = -0.3, 0.739 for t = 0.2).
  const double back = Blobs(q, leaf, -0.3, SubSeed(q.seed, 2), &n);
  const double back_shade = Lerp(0.507, std::max(-1.0, std::min(1.0, n)), noise::OctaveWeight(leaf, q.f));
  value = Lerp(value, 0.25 + 0.05 * back_shade, back);
  const double front = Blobs(q, 0.5 * leaf, 0.2, SubSeed(q.seed, 3), &n);
  const double front_shade =
      Lerp(0.739, std::max(-1.0, std::min(1.0, n)), noise::OctaveWeight(0.5 * leaf, q.f));
  value = Lerp(value, 0.42 + 0.08 * front_shade, front);
  return value + clump;
}

}  // namespace mcvo::synth::texture
