// Procedural building blocks of the synthetic textures (private to
// src/synth): an integer hash, 2-D gradient noise, band-limited fBm, and box
// filters of step patterns.
//
// "Box filter" everywhere means the mean over the footprint interval
// [x - f/2, x + f/2] (1-D) or the square [x - f/2, x + f/2] x [y - f/2, y + f/2]
// (2-D; separable patterns are filtered per axis, which is exact because the
// box filter is separable). f = 0 is a point sample. All functions are pure
// and continuous in x and f unless stated otherwise.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "mcvo/util/hash.h"

namespace mcvo::synth::noise {

using ::mcvo::Mix32;
inline uint32_t Mix(uint32_t x) { return Mix32(x); }

// Hash of a lattice point. The linear combination with large odd constants
// only collides for lattice offsets far larger than any pattern repeat we
// care about; Mix then decorrelates neighbouring points.
inline uint32_t HashLattice(int64_t ix, int64_t iy, uint32_t seed) {
  return Mix(static_cast<uint32_t>(ix) * 0x8da6b343U + static_cast<uint32_t>(iy) * 0xd8163841U + seed);
}

// Uniform in [0, 1) from a hash.
inline double Unit(uint32_t h) { return static_cast<double>(h >> 8) * (1.0 / 16777216.0); }

// The k-th uniform draw in [lo, hi) of a surface with this seed.
inline double Draw(uint32_t seed, uint32_t k, double lo = 0.0, double hi = 1.0) {
  return lo + (hi - lo) * Unit(Mix(Mix(seed) ^ (k * 0x9e3779b9U + 0x632be5abU)));
}

// Sub-seed for a component (decorrelated from other components' seeds).
inline uint32_t SubSeed(uint32_t seed, uint32_t k) { return Mix(seed + 0x7f4a7c15U * (k + 1)); }

// floor() as an integer; valid for |x| < 9e18 (callers clamp coordinates).
inline int64_t FloorToInt(double x) {
  const auto i = static_cast<int64_t>(x);
  return x < static_cast<double>(i) ? i - 1 : i;
}

inline double Clamp01(double x) { return std::min(1.0, std::max(0.0, x)); }

inline double Smoothstep(double e0, double e1, double x) {
  const double t = Clamp01((x - e0) / (e1 - e0));
  return t * t * (3.0 - 2.0 * t);
}

inline double Lerp(double a, double b, double t) { return a + (b - a) * t; }

// 2-D gradient (Perlin-style) noise on the unit lattice, in double (cracks
// differentiate it numerically), quintic
// interpolation: C2, zero at lattice points, zero mean, scaled to unit
// standard deviation (measured: raw std 0.217). Spectrum: a band around one
// cycle per lattice cell, i.e. "wavelength" ~ 1 lattice unit.
double GradientNoise(double x, double y, uint32_t seed);

// Typical |gradient| of GradientNoise per lattice unit (RMS, measured), used
// to turn a noise value into a distance to its level set.
inline constexpr double kNoiseSlope = 4.1;

// Weight of a detail of wavelength `lambda` in a footprint `f`: 1 while
// lambda >= 2.83 f, 0 once lambda <= 0.71 f (the detail then contributes its
// mean and is not evaluated), smoothstep in log2(lambda / f) in between.
// This tracks the least-squares weight of the footprint's box filter on one
// GradientNoise octave (measured: 0.07, 0.29, 0.49, 0.74, 0.84, 0.93 at
// lambda / f = 0.5, 0.75, 1, 1.5, 2, 3) while dropping every octave finer
// than 0.71 f, so nothing far above the sample rate is point-sampled.
inline double OctaveWeight(double lambda, double f) {
  const double ratio = lambda / std::max(f, 1e-12);
  if (ratio >= 2.8284271247461903) return 1.0;
  if (ratio <= 0.70710678118654752) return 0.0;
  return Smoothstep(-0.5, 1.5, std::log2(ratio));
}

// Band-limited fractional Brownian motion: octaves of GradientNoise with
// wavelengths lambda_k = wavelength / 2^k down to min_wavelength, amplitude
// gain^k (radially averaged 2-D power spectrum ~ 1/f^(2 + 2 log2(1/gain));
// natural images are ~ 1/f^2, i.e. gain ~ 1), each rotated and offset to
// hide the lattice. Octave k is weighted by OctaveWeight(lambda_k, f) and
// skipped when that is 0, so the cost falls with the footprint. Normalised to
// unit std when every octave is present; zero mean.
// `stretch_u` > 1 elongates the features along u (wood grain, brushed metal):
// the wavelength along u is stretch_u times longer; the fade uses the short one.
double Fbm(double u, double v, double f, uint32_t seed, double wavelength, double min_wavelength, double gain,
           double stretch_u = 1.0);

// Integral over [0, x] of the pulse train that is 1 on [k p, k p + w), k in Z.
inline double PulseIntegral(double x, double period, double width) {
  const double cell = std::floor(x / period);
  return cell * width + std::min(x - cell * period, width);
}

// Box filter of the pulse train 1 on [offset + k p, offset + k p + w):
// the fraction of the footprint covered by pulses (exact, closed form).
inline double PulseAverage(double x, double f, double period, double width, double offset) {
  x -= offset;
  if (f < 1e-9 * period) return x - std::floor(x / period) * period < width ? 1.0 : 0.0;
  return (PulseIntegral(x + 0.5 * f, period, width) - PulseIntegral(x - 0.5 * f, period, width)) / f;
}

// As PulseAverage, the train restricted to [lo, hi) (a finite row of pulses).
inline double PulseAverageClipped(double x, double f, double period, double width, double offset, double lo,
                                  double hi) {
  if (hi <= lo) return 0.0;
  if (f < 1e-9 * period) return x >= lo && x < hi ? PulseAverage(x, 0.0, period, width, offset) : 0.0;
  const double a = std::min(std::max(x - 0.5 * f, lo), hi) - offset;
  const double b = std::min(std::max(x + 0.5 * f, lo), hi) - offset;
  return (PulseIntegral(b, period, width) - PulseIntegral(a, period, width)) / f;
}

// Box filter of the indicator of [lo, hi).
inline double IntervalAverage(double x, double f, double lo, double hi) {
  if (f <= 0.0) return x >= lo && x < hi ? 1.0 : 0.0;
  const double overlap = std::min(x + 0.5 * f, hi) - std::max(x - 0.5 * f, lo);
  return overlap > 0.0 ? std::min(1.0, overlap / f) : 0.0;
}

// Box filter of a band of width w centred on a curve, d = signed distance
// to the curve (locally straight).
inline double BandCoverage(double d, double w, double f) { return IntervalAverage(d, f, -0.5 * w, 0.5 * w); }

// Box filter of a disc of radius r centred at offset (dx, dy) from the
// footprint centre: an edge ramp of width f while f << r (exact to first
// order for a smooth edge), blending into the exact box filter of the
// equal-area square once f > r / 4 (an isolated dot then contributes its
// area / f^2). Symmetric in (dx, dy), so coverage centroids are unbiased.
inline double DotCoverage(double dx, double dy, double r, double f) {
  const double d = std::sqrt(dx * dx + dy * dy);
  const double ramp = f > 0.0 ? Clamp01(0.5 + (r - d) / f) : (d < r ? 1.0 : 0.0);
  const double w = Smoothstep(0.25 * r, 0.5 * r, f);
  if (w <= 0.0) return ramp;
  const double half = 0.5 * r * 1.7724538509055159;  // sqrt(pi) r / 2: equal-area square
  const double square = IntervalAverage(dx, f, -half, half) * IntervalAverage(dy, f, -half, half);
  return Lerp(ramp, square, w);
}

// Coverage of the region {n > t} of a noise field of unit std and
// wavelength lambda (n = its value at the footprint centre): a ramp of width
// f across the level set, whose distance is (n - t) lambda / kNoiseSlope,
// fading to the expected coverage `mean` for f from lambda / 4 to 0.8 lambda
// (where the ramp's linearisation stops holding).
inline double ThresholdCoverage(double n, double t, double lambda, double f, double mean) {
  const double d = (n - t) * lambda / kNoiseSlope;
  const double sharp = f > 0.0 ? Clamp01(0.5 + d / f) : (d > 0.0 ? 1.0 : 0.0);
  return Lerp(sharp, mean, Smoothstep(0.25 * lambda, 0.8 * lambda, f));
}

// P(n > t) for unit-std noise (Gaussian approximation).
inline double TailProbability(double t) { return 0.5 * std::erfc(t * 0.70710678118654752); }

// The cells of period p (cell k = [offset + k p, offset + (k + 1) p)) that
// the footprint overlaps, for blending per-cell random values: `cell` with
// weight w0 and cell + 1 with 1 - w0. The footprint is clamped to one
// period, so at most two cells; callers fade per-cell variation to its mean
// as f approaches p, which keeps the blend continuous and band-limited.
struct CellSpan {
  int64_t cell;
  double w0;
};
inline CellSpan SpanCells(double x, double f, double period, double offset) {
  f = std::min(f, period);
  const double lo = x - offset - 0.5 * f;
  const int64_t cell = FloorToInt(lo / period);
  const double boundary = static_cast<double>(cell + 1) * period;
  const double w0 = f > 0.0 ? Clamp01((boundary - lo) / f) : 1.0;
  return {cell, w0};
}

}  // namespace mcvo::synth::noise
