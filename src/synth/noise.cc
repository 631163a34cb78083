#include "noise.h"

namespace mcvo::synth::noise {
namespace {

// 16 unit gradients at angles (k + 1/2) * 22.5 degrees (no axis-aligned one,
// so no octave lines up with the lattice axes).
struct Grad {
  double x;
  double y;
};
constexpr double kC1 = 0.98078528040323043;  // cos 11.25 deg
constexpr double kC2 = 0.83146961230254524;  // cos 33.75 deg
constexpr double kC3 = 0.55557023301960218;  // cos 56.25 deg
constexpr double kC4 = 0.19509032201612825;  // cos 78.75 deg
constexpr Grad kGradients[16] = {
    {kC1, kC4},  {kC2, kC3},  {kC3, kC2},   {kC4, kC1},   {-kC4, kC1},  {-kC3, kC2},
    {-kC2, kC3}, {-kC1, kC4}, {-kC1, -kC4}, {-kC2, -kC3}, {-kC3, -kC2}, {-kC4, -kC1},
    {kC4, -kC1}, {kC3, -kC2}, {kC2, -kC3},  {kC1, -kC4},
};

constexpr double kUnitStd = 1.0 / 0.217;

inline double Corner(int64_t ix, int64_t iy, uint32_t seed, double dx, double dy) {
  const Grad& g = kGradients[HashLattice(ix, iy, seed) >> 28];
  return g.x * dx + g.y * dy;
}

inline double Quintic(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

}  // namespace

double GradientNoise(double x, double y, uint32_t seed) {
  const int64_t ix = FloorToInt(x);
  const int64_t iy = FloorToInt(y);
  const double fx = x - static_cast<double>(ix);
  const double fy = y - static_cast<double>(iy);
  const double n00 = Corner(ix, iy, seed, fx, fy);
  const double n10 = Corner(ix + 1, iy, seed, fx - 1.0, fy);
  const double n01 = Corner(ix, iy + 1, seed, fx, fy - 1.0);
  const double n11 = Corner(ix + 1, iy + 1, seed, fx - 1.0, fy - 1.0);
  const double sx = Quintic(fx);
  const double sy = Quintic(fy);
  const double bottom = n00 + (n10 - n00) * sx;
  const double top = n01 + (n11 - n01) * sx;
  return kUnitStd * (bottom + (top - bottom) * sy);
}

double Fbm(double u, double v, double f, uint32_t seed, double wavelength, double min_wavelength, double gain,
           double stretch_u) {
  // Octave k samples noise at R^k (u / stretch_u, v) / lambda_k with R a
  // rotation by atan(3/4) (exact rational entries) plus an offset, so the
  // lattices of successive octaves never align (no rotation when stretched).
  double x = u / (wavelength * stretch_u);
  double y = v / wavelength;
  double lambda = wavelength;
  double amplitude = 1.0;
  double sum = 0.0;
  double energy = 0.0;
  bool active = true;
  for (uint32_t k = 0; k < 24 && lambda >= min_wavelength * 0.999; ++k) {
    energy += amplitude * amplitude;
    if (active) {
      const double w = OctaveWeight(lambda, f);
      if (w <= 0.0) {
        active = false;  // this and all finer octaves are averaged out
      } else {
        sum += w * amplitude * GradientNoise(x, y, seed + k * 0x3c6ef373U);
      }
    }
    if (stretch_u == 1.0) {
      const double rx = 1.6 * x - 1.2 * y + 17.31;
      y = 1.2 * x + 1.6 * y + 5.87;
      x = rx;
    } else {  // keep the elongation axis: scale and offset only
      x = 2.0 * x + 17.31;
      y = 2.0 * y + 5.87;
    }
    lambda *= 0.5;
    amplitude *= gain;
  }
  return energy > 0.0 ? sum / std::sqrt(energy) : 0.0;
}

}  // namespace mcvo::synth::noise
