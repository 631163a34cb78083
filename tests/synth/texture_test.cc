// Tests of the procedural textures (src/synth/texture*.cc): range, band
// limiting (footprint value vs the mean of point samples, variance falling
// with the footprint), continuity, natural power spectra, weak texture of
// wall paint, the marker's centroid and radius, determinism.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "mcvo/synth/material.h"

namespace mcvo::synth {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<Material> SurfaceMaterials() {
  std::vector<Material> materials;
  for (int m = 1; m < kNumMaterials; ++m) materials.push_back(static_cast<Material>(m));
  return materials;
}

// Extents that suit the material (markings are long thin quads, shop fronts
// one floor high, posters billboard-sized).
void TypicalExtents(Material material, double* extent_u, double* extent_v) {
  *extent_u = 40.0;
  *extent_v = 20.0;
  if (material == Material::kRoadMarking) *extent_v = 0.2;
  if (material == Material::kShopFront) *extent_v = 4.5;
  if (material == Material::kPoster) *extent_u = 1.2, *extent_v = 1.8;
  if (material == Material::kMarker) *extent_u = 0.8, *extent_v = 0.6;
}

double Shade(Material material, uint32_t seed, double u, double v, double footprint) {
  double eu = 0.0;
  double ev = 0.0;
  TypicalExtents(material, &eu, &ev);
  return ShadeSurface(material, seed, u, v, footprint, eu, ev);
}

// Mean of n x n point samples (footprint 1e-4 m) at the centres of a grid
// over the f x f square centred at (u, v): the box filter by brute force.
double BoxMean(Material material, uint32_t seed, double u, double v, double f, int n) {
  double sum = 0.0;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      sum += Shade(material, seed, u + f * ((i + 0.5) / n - 0.5), v + f * ((j + 0.5) / n - 0.5), 1e-4);
    }
  }
  return sum / (n * n);
}

TEST(Texture, ValuesInRangeEverywhere) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (Material material : SurfaceMaterials()) {
    for (int i = 0; i < 3000; ++i) {
      const double scale = std::pow(10.0, -1.0 + 9.0 * unit(rng));  // 0.1 m .. 1e8 m, both signs
      const double u = (2.0 * unit(rng) - 1.0) * scale;
      const double v = (2.0 * unit(rng) - 1.0) * scale;
      const double f = std::pow(10.0, -4.0 + 6.0 * unit(rng));  // 1e-4 .. 100 m
      const double eu = std::pow(10.0, -1.0 + 3.0 * unit(rng));
      const double ev = std::pow(10.0, -1.0 + 3.0 * unit(rng));
      const float value = ShadeSurface(material, static_cast<uint32_t>(i * 7919), u, v, f, eu, ev);
      ASSERT_TRUE(value >= 0.0f && value <= 1.0f)
          << MaterialName(material) << " " << u << " " << v << " " << f;
    }
    // Degenerate inputs never give NaN or out-of-range values.
    for (double bad : {0.0, -1.0, 1e300, -1e300, std::nan(""), HUGE_VAL}) {
      const float value = ShadeSurface(material, 3, bad, bad, bad, bad, bad);
      EXPECT_TRUE(value >= 0.0f && value <= 1.0f) << MaterialName(material);
    }
  }
  for (int i = 0; i < 2000; ++i) {
    const double dx = 2.0 * unit(rng) - 1.0;
    const double dy = 2.0 * unit(rng) - 1.0;
    const double dz = 2.0 * unit(rng) - 1.0;
    const float value = ShadeSky(dx, dy, dz);
    ASSERT_TRUE(value >= 0.0f && value <= 1.0f);
  }
  EXPECT_TRUE(ShadeSky(0.0, 0.0, 0.0) >= 0.0f);
}

// The value at footprint F must be the mean over the F x F square. Sources
// of honest error: octaves whose wavelength is between F and 2F are kept
// partially (weight smoothstep(1, 2, lambda / F)) while the true box mean
// attenuates them by up to sinc(1/2) ~ 0.64 only; per-cell tones and level
// sets fade to their mean a little early. Those are fine-scale components
// of std <~ 0.05 in albedo, so the error is a fraction of that; steps and
// stripes are exact. The brute-force mean itself has an error of about
// (point-sample std) / 40 ~ 0.005.
TEST(Texture, FootprintValueIsTheBoxMean) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (Material material : SurfaceMaterials()) {
    double eu = 0.0;
    double ev = 0.0;
    TypicalExtents(material, &eu, &ev);
    for (double f : {0.05, 0.5}) {
      double sum_abs = 0.0;
      double max_abs = 0.0;
      const int trials = 40;
      for (int t = 0; t < trials; ++t) {
        const double u = eu * unit(rng);
        const double v = ev * unit(rng);
        const double error = Shade(material, 5, u, v, f) - BoxMean(material, 5, u, v, f, 40);
        sum_abs += std::abs(error);
        max_abs = std::max(max_abs, std::abs(error));
      }
      std::printf("%-15s F=%.2f mean|err|=%.4f max|err|=%.4f\n", std::string(MaterialName(material)).c_str(),
                  f, sum_abs / trials, max_abs);
      // Layered materials composite box-filtered layers in paint order
      // (lerp by coverage), exact only where layers do not overlap inside
      // the footprint, and their level sets (leaves, blobs) sit at the
      // footprint scale at F = 5 cm: looser bounds for those.
      const bool layered =
          material == Material::kPoster || material == Material::kShopFront || material == Material::kFoliage;
      EXPECT_LT(sum_abs / trials, layered ? 0.05 : 0.03) << MaterialName(material) << " F=" << f;
      EXPECT_LT(max_abs, layered ? 0.2 : 0.1) << MaterialName(material) << " F=" << f;
    }
  }
}

double VarianceOverSurface(Material material, double f, std::mt19937* rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double eu = 0.0;
  double ev = 0.0;
  TypicalExtents(material, &eu, &ev);
  double sum = 0.0;
  double sum2 = 0.0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const double value = Shade(material, 9, eu * unit(*rng), ev * unit(*rng), f);
    sum += value;
    sum2 += value * value;
  }
  const double mean = sum / n;
  return sum2 / n - mean * mean;
}

// No aliasing: averaging over a larger footprint can only remove contrast.
TEST(Texture, VarianceFallsWithFootprint) {
  std::mt19937 rng(3);
  for (Material material : SurfaceMaterials()) {
    const double v_fine = VarianceOverSurface(material, 0.01, &rng);
    const double v_mid = VarianceOverSurface(material, 0.3, &rng);
    const double v_coarse = VarianceOverSurface(material, 3.0, &rng);
    std::printf("%-15s var(1cm)=%.5f var(30cm)=%.5f var(3m)=%.5f\n",
                std::string(MaterialName(material)).c_str(), v_fine, v_mid, v_coarse);
    EXPECT_LE(v_mid, 1.1 * v_fine) << MaterialName(material);
    EXPECT_LE(v_coarse, 1.1 * v_mid) << MaterialName(material);
  }
  // Bricks: the bond and the tones are gone at 1 m, only windows and
  // weathering remain; compared on a wall without windows (a 2 m high quad).
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto brick_variance = [&](double f) {
    double sum = 0.0;
    double sum2 = 0.0;
    const int n = 4000;
    for (int i = 0; i < n; ++i) {
      const double value =
          ShadeSurface(Material::kFacadeBrick, 4, 30.0 * unit(rng), 2.0 * unit(rng), f, 30.0, 2.0);
      sum += value;
      sum2 += value * value;
    }
    return sum2 / n - (sum / n) * (sum / n);
  };
  EXPECT_LT(brick_variance(1.0), 0.25 * brick_variance(0.01));
}

TEST(Texture, ContinuousInPositionAndFootprint) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (Material material : SurfaceMaterials()) {
    double eu = 0.0;
    double ev = 0.0;
    TypicalExtents(material, &eu, &ev);
    double worst_u = 0.0;
    double worst_f = 0.0;
    for (int i = 0; i < 20000; ++i) {
      const double u = eu * unit(rng);
      const double v = ev * unit(rng);
      const double f = std::pow(10.0, -3.0 + 3.0 * unit(rng));  // 1 mm .. 1 m
      const double value = Shade(material, 11, u, v, f);
      // The steepest legal slope is a full-contrast step seen through the
      // footprint: 1 / f per metre, i.e. 1e-3 for du = 1e-6 at f = 1 mm.
      worst_u = std::max(worst_u, std::abs(Shade(material, 11, u + 1e-6, v, f) - value) * f / 1e-6);
      worst_f = std::max(worst_f, std::abs(Shade(material, 11, u, v, f * (1.0 + 1e-4)) - value));
    }
    EXPECT_LT(worst_u, 4.0) << MaterialName(material) << " (slope in contrast per footprint)";
    EXPECT_LT(worst_f, 2e-3) << MaterialName(material);
  }
}

// Slope of the radially averaged power spectrum of an n x n patch sampled
// at spacing h with the given footprint, Hann-windowed, fitted on log-log
// over the frequency band [4, n/4) cycles per patch (below half the
// Nyquist rate, where the footprint filter has not started to cut).
double SpectralSlope(Material material, uint32_t seed, double u0, double v0, double h, double footprint,
                     int n) {
  cv::Mat patch(n, n, CV_64F);
  double mean = 0.0;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      patch.at<double>(y, x) = Shade(material, seed, u0 + x * h, v0 + y * h, footprint);
      mean += patch.at<double>(y, x);
    }
  }
  mean /= n * n;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const double w = (0.5 - 0.5 * std::cos(2.0 * kPi * x / n)) * (0.5 - 0.5 * std::cos(2.0 * kPi * y / n));
      patch.at<double>(y, x) = (patch.at<double>(y, x) - mean) * w;
    }
  }
  cv::Mat spectrum;
  cv::dft(patch, spectrum, cv::DFT_COMPLEX_OUTPUT);
  std::vector<double> power(n / 2, 0.0);
  std::vector<int> count(n / 2, 0);
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const int fy = y <= n / 2 ? y : y - n;
      const int fx = x <= n / 2 ? x : x - n;
      const int r = static_cast<int>(std::lround(std::sqrt(fx * fx + fy * fy)));
      if (r < n / 2) {
        const cv::Vec2d c = spectrum.at<cv::Vec2d>(y, x);
        power[r] += c[0] * c[0] + c[1] * c[1];
        ++count[r];
      }
    }
  }
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  int m = 0;
  for (int r = 4; r < n / 4; ++r) {
    const double lx = std::log(r);
    const double ly = std::log(power[r] / count[r]);
    sx += lx;
    sy += ly;
    sxx += lx * lx;
    sxy += lx * ly;
    ++m;
  }
  return -(m * sxy - sx * sy) / (m * sxx - sx * sx);
}

// Point samples (footprint 1e-4) at 1 mm resolve every octave; at
// coarser spacings each sample's footprint is the spacing (one sample per
// pixel; point samples or smaller footprints there alias the sub-sample
// grain into white noise and flatten the spectrum).
TEST(Texture, NaturalPowerSpectrum) {
  struct Case {
    Material material;
    double spacing;  // metres per sample
    double footprint;
  };
  for (const Case& c : {Case{Material::kFacadeBrick, 0.01, 0.01}, Case{Material::kFacadeBrick, 0.002, 1e-4},
                        Case{Material::kAsphalt, 0.001, 1e-4}, Case{Material::kAsphalt, 0.01, 0.01},
                        Case{Material::kAsphalt, 0.05, 0.05}, Case{Material::kGrass, 0.001, 1e-4},
                        Case{Material::kGrass, 0.01, 0.01}, Case{Material::kGrass, 0.05, 0.05}}) {
    double slope_sum = 0.0;
    for (uint32_t seed = 0; seed < 3; ++seed) {
      slope_sum += SpectralSlope(c.material, seed, 3.0, 0.3, c.spacing, c.footprint, 256);
    }
    const double slope = slope_sum / 3.0;
    std::printf("%-15s spacing %.3f m footprint %.4f m: power ~ 1/f^%.2f\n",
                std::string(MaterialName(c.material)).c_str(), c.spacing, c.footprint, slope);
    EXPECT_GT(slope, 1.0) << MaterialName(c.material);
    EXPECT_LT(slope, 3.0) << MaterialName(c.material);
  }
}

double PatchStd(Material material, uint32_t seed, double u0, double v0, double extent_u, double extent_v) {
  double sum = 0.0;
  double sum2 = 0.0;
  const int n = 64;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double value =
          ShadeSurface(material, seed, u0 + 0.5 * i / n, v0 + 0.5 * j / n, 0.5 / n, extent_u, extent_v);
      sum += value;
      sum2 += value * value;
    }
  }
  const double mean = sum / (n * n);
  return std::sqrt(std::max(0.0, sum2 / (n * n) - mean * mean));
}

// The weak-texture case: a 0.5 m patch of wall paint has under a tenth of
// the local contrast of a poster.
TEST(Texture, WallPaintIsNearlyTextureless) {
  double paint = 0.0;
  double poster = 0.0;
  for (uint32_t seed = 0; seed < 8; ++seed) {
    paint += PatchStd(Material::kWallPaint, seed, 1.0 + seed, 1.2, 10.0, 3.0);
    poster += PatchStd(Material::kPoster, seed, 0.3, 0.6, 1.2, 1.8);
  }
  std::printf("0.5 m patch std: wall paint %.4f, poster %.4f\n", paint / 8, poster / 8);
  EXPECT_LT(paint, 0.1 * poster);
  EXPECT_LT(paint / 8, 0.01);
}

// Coverage-weighted centroid of the rendered marker quad: unbiased to 1e-3
// of the extent, on grids not symmetric about the centre; area = pi r^2 with
// r = 0.35 x the shorter side.
TEST(Texture, MarkerCentroidAndRadius) {
  const double eu = 0.8;
  const double ev = 0.6;
  for (int n : {24, 64, 201}) {
    const double h = eu / n;  // square pixels, footprint = pixel
    for (double phase : {0.0, 0.3, 0.71}) {
      double w_sum = 0.0, wu = 0.0, wv = 0.0;
      for (int j = -2; j < static_cast<int>(ev / h) + 2; ++j) {
        for (int i = -2; i < n + 2; ++i) {
          const double u = (i + phase) * h;
          const double v = (j + 0.5 * phase) * h;
          const double w = (ShadeSurface(Material::kMarker, 0, u, v, h, eu, ev) - 0.02) / 0.93;
          w_sum += w;
          wu += w * u;
          wv += w * v;
        }
      }
      EXPECT_NEAR(wu / w_sum, 0.5 * eu, 1e-3 * eu) << "n " << n << " phase " << phase;
      EXPECT_NEAR(wv / w_sum, 0.5 * ev, 1e-3 * eu) << "n " << n << " phase " << phase;
      const double radius = std::sqrt(w_sum * h * h / kPi);
      EXPECT_NEAR(radius, 0.35 * ev, 0.01 * 0.35 * ev) << "n " << n;
    }
  }
  EXPECT_NEAR(ShadeSurface(Material::kMarker, 0, 0.4, 0.3, 0.001, eu, ev), 0.95, 1e-6);
  EXPECT_NEAR(ShadeSurface(Material::kMarker, 0, 0.05, 0.05, 0.001, eu, ev), 0.02, 1e-6);
}

TEST(Texture, DeterministicAndSeedDependent) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (Material material : SurfaceMaterials()) {
    for (int i = 0; i < 100; ++i) {
      const double u = 30.0 * unit(rng);
      const double v = 15.0 * unit(rng);
      EXPECT_EQ(Shade(material, 77, u, v, 0.01), Shade(material, 77, u, v, 0.01));
    }
  }
  for (Material material :
       {Material::kFacadePlaster, Material::kFacadeBrick, Material::kShopFront, Material::kPoster}) {
    double difference = 0.0;
    for (int i = 0; i < 400; ++i) {
      const double u = 1.2 * unit(rng);
      const double v = 1.8 * unit(rng);
      difference += std::abs(Shade(material, 1, u, v, 0.005) - Shade(material, 2, u, v, 0.005));
    }
    EXPECT_GT(difference / 400, 0.02) << MaterialName(material);
  }
}

}  // namespace
}  // namespace mcvo::synth
