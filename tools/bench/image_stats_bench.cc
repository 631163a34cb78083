// Image statistics of a dataset's cameras, to compare real recordings with
// `mcvo synth` renders (results/render_realism.md, tools/bench_render_realism.sh).
//
//   mcvo_bench_image_stats DIR [--format F] [--frames N] [--temporal] [--flat-share X]
//
// DIR is any dataset mcvo reads (OpenDataset: generic, kitti, euroc, ...).
// --frames N measures N frames evenly spaced over the sequence (default:
// all); --temporal adds a per-pixel temporal noise estimate (meaningful only
// for a rig that stands still). Prints one JSON object: per camera, over the
// measured frames (valid pixels of the camera's mask only):
//
//  noise     spatial (temporal-free) noise sigma per brightness bin (8 bins
//            of 32 grey levels): the residual of Immerkaer's 3x3 high-pass
//            [1 -2 1; -2 4 -2; 1 -2 1] / 6 (std = sigma for white noise),
//            pooled over the 20 % flattest 8x8 blocks of each bin in each
//            frame (flatness: mean gradient of the image blurred with a
//            Gaussian of 2 px, so the selection hardly sees the noise),
//            blocks with a clipped pixel (0 or 255) near them left out.
//            sigma = clipped RMS (|r| <= 3 MAD-sigmas, corrected for the
//            truncation); sigma_mad = 1.4826 x median |r|. fit: least squares
//            of sigma^2 = a * mean + b over the bins with >= 2000 pixels
//            (the Poisson-Gaussian model of `mcvo synth --sensor-noise A:B`),
//            relative error (weights 1 / sigma^4); fit_lower: the same
//            with the bins far above the line dropped one by one (fine
//            texture the high-pass cannot tell from noise: asphalt, grass).
//  temporal_noise (--temporal) sqrt of half the mean squared difference of
//            consecutive frames, in the flat blocks (as above) of the mean
//            image, per bin of its brightness.
// --flat-share X: the share of each bin's flattest blocks pooled (default 0.2).
//  sharpness step edges along x and along y (gradient within 11 deg of an
//            axis, local maximum of |gradient|, contrast >= 30 over 9 px,
//            flat and monotone sides): the ratio of the peak central
//            difference to the contrast over +-4 px, averaged, inverted
//            through the same ratio of an ideal edge: a step, integrated
//            over the 1-px pixel, blurred by a Gaussian of sigma px (mean
//            over sub-pixel phases). sigma_px is that equivalent Gaussian
//            PSF (what `mcvo synth --lens-blur SIGMA` adds), 0 for an
//            edge as sharp as a pixel; edge_width_px the 10-90 % rise of
//            that model edge.
//  vignetting mean brightness over all frames in 10 radius bins (distance
//            from the image centre over the half diagonal) relative to the
//            centre bin (scene content is in it as much as the lens).
//  exposure  grey-level percentiles (1, 5, 50, 95, 99), the fractions of
//            pixels at 0 and at 255, the mean, the mean per-frame std, the
//            histogram (256 pixel counts).
//  texture   cv::cornerMinEigenVal (grey levels 0..255 as float, block 3,
//            Sobel 3) median and 90th percentile; the fractions of pixels
//            whose gradient (Sobel / 8, grey levels per px) exceeds 4 and
//            16; FAST corners (threshold 20, non-max suppression) per 10^4
//            px; the slope of the radially averaged power spectrum of a
//            central 256 x 256 crop (Hann window) over 0.02-0.25 cycles/px
//            (natural images: about -2).
//  compression JPEG blockiness: the mean |difference| of neighbouring pixels
//            across each column (row) phase mod 8, the largest over the
//            mean of the others, and the phase-7 (8x8 grid) ratio; about 1
//            without block coding.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/dataset/dataset.h"

namespace {

constexpr int kBins = 8;                  // brightness bins of 32 grey levels
constexpr int kBlock = 8;                 // noise blocks
constexpr double kMinFitPixels = 2000.0;  // pooled pixels a bin needs to enter the noise fits
double g_flattest = 0.2;                  // share of a bin's blocks pooled (--flat-share)
constexpr int kResidualLevels = 4096;     // |6 r| is an integer in [0, 4080] for 8-bit images
constexpr int kEdgeHalf = 4;              // edge profile +-4 px
constexpr double kMinEdgeContrast = 30.0;
constexpr int kRadiusBins = 10;
constexpr int kEigenBins = 1200;  // log10(lambda) in [-4, 8) by 0.01
constexpr int kSpectrumSize = 256;

struct NoiseBins {
  std::array<std::vector<double>, kBins> residual;  // histogram of |6 r|
  std::array<double, kBins> brightness_sum{};       // per pixel
  std::array<double, kBins> pixels{};
  std::array<double, kBins> variance_sum{};  // temporal: per-pixel variance summed
  NoiseBins() {
    for (auto& h : residual) h.assign(kResidualLevels, 0.0);
  }
};

struct CameraStats {
  NoiseBins noise;
  NoiseBins temporal;
  cv::Mat sum;       // per pixel, CV_64F (vignetting; the temporal estimate's bins)
  cv::Mat diff_sq;   // per pixel, CV_64F: sum of squared differences of consecutive frames
  cv::Mat previous;  // the last frame, CV_64F
  int frames = 0;
  std::vector<double> edge_ratios;
  std::array<double, 256> histogram{};
  double frame_std_sum = 0.0;
  std::vector<double> eigen_hist = std::vector<double>(kEigenBins, 0.0);
  double gradient_over_4 = 0.0, gradient_over_16 = 0.0, valid_pixels = 0.0, fast_corners = 0.0;
  double spectrum_slope_sum = 0.0;
  int spectrum_frames = 0;
  std::array<double, 8> diff_x{}, count_x{}, diff_y{}, count_y{};
};

// Valid pixels (255) of a camera: its mask, or every pixel.
cv::Mat ValidMask(const cv::Mat& mask, cv::Size size) {
  if (mask.empty()) return cv::Mat(size, CV_8UC1, cv::Scalar(255));
  return mask > 0;
}

// The 8x8 blocks whose pixels (and a 3-px margin) are valid and unclipped,
// with their brightness and flatness, and per brightness bin the flattest
// g_flattest of them. `image` CV_32F grey levels.
struct Block {
  int x = 0, y = 0;
  float mean = 0.0f, structure = 0.0f;
};
std::array<std::vector<Block>, kBins> FlattestBlocks(const cv::Mat& image, const cv::Mat& valid) {
  cv::Mat smooth, gx, gy, structure;
  cv::GaussianBlur(image, smooth, cv::Size(0, 0), 2.0);
  cv::Sobel(smooth, gx, CV_32F, 1, 0, 3, 1.0 / 8.0);
  cv::Sobel(smooth, gy, CV_32F, 0, 1, 3, 1.0 / 8.0);
  cv::magnitude(gx, gy, structure);
  cv::Mat usable = valid.clone();
  usable.setTo(0, image <= 0.5f);
  usable.setTo(0, image >= 254.5f);
  cv::erode(usable, usable, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(7, 7)));
  std::array<std::vector<Block>, kBins> bins;
  for (int y = 4; y + kBlock + 4 <= image.rows; y += kBlock) {
    for (int x = 4; x + kBlock + 4 <= image.cols; x += kBlock) {
      const cv::Rect rect(x, y, kBlock, kBlock);
      if (cv::countNonZero(usable(rect)) != kBlock * kBlock) continue;
      Block block{x, y, static_cast<float>(cv::mean(image(rect))[0]),
                  static_cast<float>(cv::mean(structure(rect))[0])};
      bins[std::min(kBins - 1, static_cast<int>(block.mean / 32.0f))].push_back(block);
    }
  }
  for (auto& blocks : bins) {
    std::sort(blocks.begin(), blocks.end(), [](const Block& a, const Block& b) {
      return a.structure < b.structure ||
             (a.structure == b.structure && (a.y < b.y || (a.y == b.y && a.x < b.x)));
    });
    blocks.resize(static_cast<size_t>(std::ceil(g_flattest * static_cast<double>(blocks.size()))));
  }
  return bins;
}

void AccumulateNoise(const cv::Mat& image, const cv::Mat& valid, NoiseBins* noise) {
  const cv::Mat kernel = (cv::Mat_<float>(3, 3) << 1, -2, 1, -2, 4, -2, 1, -2, 1);
  cv::Mat residual;  // 6 r, exact integers in float
  cv::filter2D(image, residual, CV_32F, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT_101);
  const auto bins = FlattestBlocks(image, valid);
  for (int bin = 0; bin < kBins; ++bin) {
    for (const Block& block : bins[bin]) {
      for (int y = block.y; y < block.y + kBlock; ++y) {
        const float* r = residual.ptr<float>(y);
        for (int x = block.x; x < block.x + kBlock; ++x) {
          const int level = std::min(kResidualLevels - 1, static_cast<int>(std::lround(std::abs(r[x]))));
          noise->residual[bin][level] += 1.0;
        }
      }
      noise->brightness_sum[bin] += block.mean * kBlock * kBlock;
      noise->pixels[bin] += kBlock * kBlock;
    }
  }
}

// Quantile of a histogram whose bin i holds the value i.
double HistogramQuantile(const std::vector<double>& hist, double q) {
  double total = 0.0;
  for (double c : hist) total += c;
  double seen = 0.0;
  for (size_t i = 0; i < hist.size(); ++i) {
    seen += hist[i];
    if (seen >= q * total && hist[i] > 0.0) return static_cast<double>(i);
  }
  return static_cast<double>(hist.size() - 1);
}

// sigma from the |6 r| histogram: the MAD estimate and the RMS within
// 3 MAD-sigmas, corrected for the truncation of a Gaussian at 3 sigma.
std::pair<double, double> ResidualSigma(const std::vector<double>& hist) {
  const double mad = 1.4826 * HistogramQuantile(hist, 0.5) / 6.0;
  const double limit = 3.0 * std::max(mad, 1.0 / 6.0) * 6.0;
  double sum_sq = 0.0, count = 0.0;
  for (size_t i = 0; i < hist.size() && static_cast<double>(i) <= limit; ++i) {
    sum_sq += hist[i] * static_cast<double>(i * i);
    count += hist[i];
  }
  const double rms = count > 0.0 ? std::sqrt(sum_sq / count / 0.9733) / 6.0 : 0.0;
  return {rms, mad};
}

struct NoisePoint {
  int lo = 0;
  double mean = 0.0, variance = 0.0;
};

struct NoiseLine {
  bool ok = false;
  double a = 0.0, b = 0.0;
};

// sigma^2 = a * mean + b by least squares of the relative error (weights
// 1 / variance^2, so that dark and bright bins count alike); not ok for
// fewer than 2 points.
NoiseLine FitNoiseLine(const std::vector<NoisePoint>& points) {
  double s_w = 0, s_wx = 0, s_wy = 0, s_wxx = 0, s_wxy = 0;
  for (const NoisePoint& p : points) {
    const double w = 1.0 / std::max(1e-6, p.variance * p.variance);
    s_w += w, s_wx += w * p.mean, s_wy += w * p.variance, s_wxx += w * p.mean * p.mean;
    s_wxy += w * p.mean * p.variance;
  }
  const double det = s_w * s_wxx - s_wx * s_wx;
  NoiseLine line;
  if (points.size() < 2 || !(std::abs(det) > 1e-12 * s_w * s_wxx)) return line;
  line.ok = true;
  line.a = (s_w * s_wxy - s_wx * s_wy) / det;
  line.b = (s_wy - line.a * s_wx) / s_w;
  return line;
}

// The fit over every bin, and the lower envelope: the bin farthest above
// the line (fine texture that passes for noise) dropped while it is more
// than 30 % above it in variance and more than 3 bins remain.
void AddNoiseFits(std::vector<NoisePoint> points, nlohmann::ordered_json* out) {
  const NoiseLine all = FitNoiseLine(points);
  if (!all.ok) return;
  (*out)["fit"] = {{"a", all.a}, {"b", all.b}};
  NoiseLine lower = all;
  while (points.size() > 3) {
    size_t worst = 0;
    double excess = -1.0;
    for (size_t i = 0; i < points.size(); ++i) {
      const double line = lower.a * points[i].mean + lower.b;
      const double e = line > 0.0 ? points[i].variance / line - 1.0 : 1e9;
      if (e > excess) excess = e, worst = i;
    }
    if (excess <= 0.3) break;
    points.erase(points.begin() + static_cast<std::ptrdiff_t>(worst));
    lower = FitNoiseLine(points);
  }
  nlohmann::ordered_json used = nlohmann::ordered_json::array();
  for (const NoisePoint& p : points) used.push_back(p.lo);
  (*out)["fit_lower"] = {{"a", lower.a}, {"b", lower.b}, {"bins", used}};
}

nlohmann::ordered_json NoiseJson(const NoiseBins& noise, bool temporal) {
  nlohmann::ordered_json bins = nlohmann::ordered_json::array();
  std::vector<NoisePoint> points;
  for (int bin = 0; bin < kBins; ++bin) {
    nlohmann::ordered_json j;
    j["lo"] = 32 * bin;
    j["hi"] = 32 * (bin + 1);
    j["pixels"] = noise.pixels[bin];
    if (noise.pixels[bin] <= 0.0) {
      bins.push_back(j);
      continue;
    }
    const double mean = noise.brightness_sum[bin] / noise.pixels[bin];
    double sigma = 0.0;
    j["mean"] = mean;
    if (temporal) {
      sigma = std::sqrt(noise.variance_sum[bin] / noise.pixels[bin]);
      j["sigma"] = sigma;
    } else {
      const auto [rms, mad] = ResidualSigma(noise.residual[bin]);
      sigma = rms;
      j["sigma"] = rms;
      j["sigma_mad"] = mad;
    }
    if (noise.pixels[bin] >= kMinFitPixels) points.push_back({32 * bin, mean, sigma * sigma});
    bins.push_back(j);
  }
  nlohmann::ordered_json out;
  out["bins"] = bins;
  AddNoiseFits(points, &out);
  return out;
}

// Edge profile ratios (peak central difference / contrast) of the edges
// across x; the caller passes the transposed image for the edges across y.
void CollectEdgeRatios(const cv::Mat& image, const cv::Mat& valid, std::vector<double>* ratios) {
  cv::Mat gx, gy;
  cv::Sobel(image, gx, CV_32F, 1, 0, 3, 1.0 / 8.0);
  cv::Sobel(image, gy, CV_32F, 0, 1, 3, 1.0 / 8.0);
  constexpr int r = kEdgeHalf;
  for (int y = 1; y + 1 < image.rows; ++y) {
    const float* rows[3] = {image.ptr<float>(y - 1), image.ptr<float>(y), image.ptr<float>(y + 1)};
    const uint8_t* ok[3] = {valid.ptr<uint8_t>(y - 1), valid.ptr<uint8_t>(y), valid.ptr<uint8_t>(y + 1)};
    const float* g = gx.ptr<float>(y);
    const float* g_other = gy.ptr<float>(y);
    for (int x = r + 1; x + r + 1 < image.cols; ++x) {
      const float peak = std::abs(g[x]);
      if (peak < 5.0f || !(peak > std::abs(g[x - 1]) && peak >= std::abs(g[x + 1]))) continue;
      if (5.0f * std::abs(g_other[x]) > peak) continue;
      double p[2 * r + 1];
      bool usable = true;
      for (int k = -r; k <= r && usable; ++k) {
        const int i = x + k;
        for (int row = 0; row < 3; ++row) {
          usable &= ok[row][i] != 0 && rows[row][i] > 0.5f && rows[row][i] < 254.5f;
        }
        p[k + r] = 0.25 * (rows[0][i] + 2.0 * rows[1][i] + rows[2][i]);
      }
      if (!usable) continue;
      const double sign = g[x] > 0.0f ? 1.0 : -1.0;
      const double contrast = sign * (p[2 * r] - p[0]);
      if (contrast < kMinEdgeContrast) continue;
      if (std::abs(p[2 * r] - p[2 * r - 1]) > 0.1 * contrast || std::abs(p[1] - p[0]) > 0.1 * contrast)
        continue;
      for (int k = 0; k < 2 * r && usable; ++k) usable = sign * (p[k + 1] - p[k]) >= -0.05 * contrast;
      if (usable) ratios->push_back(peak / contrast);
    }
  }
}

// The model edge: a unit step at `phase`, integrated over pixels of 1 px,
// blurred by a Gaussian of sigma; the value of pixel k.
double ModelPixel(int k, double phase, double sigma) {
  const double lo = k - 0.5 - phase, hi = k + 0.5 - phase;
  if (sigma < 1e-6) return std::clamp(hi, 0.0, 1.0);  // the step's integral over [lo, lo + 1]
  // integral of Phi(x / sigma) = sigma (t Phi(t) + phi(t)), t = x / sigma
  auto integral = [sigma](double x) {
    const double t = x / sigma;
    return sigma *
           (t * 0.5 * std::erfc(-t / std::sqrt(2.0)) + std::exp(-0.5 * t * t) / std::sqrt(2.0 * M_PI));
  };
  return integral(hi) - integral(lo);
}

// The continuous model edge (the step integrated over a 1-px box, blurred).
double ModelEdge(double x, double sigma) { return ModelPixel(0, -x, sigma); }

// Mean over sub-pixel phases of what CollectEdgeRatios measures on the model edge.
double ModelRatio(double sigma) {
  constexpr int kPhases = 64;
  double sum = 0.0;
  for (int ph = 0; ph < kPhases; ++ph) {
    const double phase = (ph + 0.5) / kPhases;
    double v[21];
    for (int k = -10; k <= 10; ++k) v[k + 10] = ModelPixel(k, phase, sigma);
    int best = 0;
    double best_g = -1.0;
    for (int k = -3; k <= 3; ++k) {
      const double g = 0.5 * (v[k + 11] - v[k + 9]);
      if (g > best_g) best_g = g, best = k;
    }
    sum += best_g / (v[best + 10 + kEdgeHalf] - v[best + 10 - kEdgeHalf]);
  }
  return sum / kPhases;
}

nlohmann::ordered_json SharpnessJson(const std::vector<double>& ratios) {
  nlohmann::ordered_json j;
  j["edges"] = ratios.size();
  if (ratios.empty()) return j;
  double mean = 0.0;
  for (double r : ratios) mean += r;
  mean /= static_cast<double>(ratios.size());
  std::vector<double> sorted = ratios;
  std::sort(sorted.begin(), sorted.end());
  j["ratio_mean"] = mean;
  j["ratio_median"] = sorted[sorted.size() / 2];
  // Invert the (decreasing) model ratio.
  double sigma = 0.0;
  for (double s = 0.0; s <= 4.0; s += 0.005) {
    if (ModelRatio(s) < mean) break;
    sigma = s;
  }
  j["sigma_px"] = sigma;
  auto crossing = [sigma](double level) {
    double lo = -6.0, hi = 6.0;
    for (int i = 0; i < 60; ++i) (ModelEdge(0.5 * (lo + hi), sigma) < level ? lo : hi) = 0.5 * (lo + hi);
    return 0.5 * (lo + hi);
  };
  j["edge_width_px"] = crossing(0.9) - crossing(0.1);
  return j;
}

double SpectrumSlope(const cv::Mat& image) {
  const int n = kSpectrumSize;
  if (image.rows < n || image.cols < n) return std::nan("");
  cv::Mat crop = image(cv::Rect((image.cols - n) / 2, (image.rows - n) / 2, n, n)).clone();
  crop -= cv::mean(crop)[0];
  cv::Mat window;
  cv::createHanningWindow(window, crop.size(), CV_32F);
  crop = crop.mul(window);
  cv::Mat spectrum;
  cv::dft(crop, spectrum, cv::DFT_COMPLEX_OUTPUT);
  std::vector<double> power(n / 2, 0.0), count(n / 2, 0.0);
  for (int v = 0; v < n; ++v) {
    for (int u = 0; u < n; ++u) {
      const int fu = u <= n / 2 ? u : u - n, fv = v <= n / 2 ? v : v - n;
      const int radius = static_cast<int>(std::lround(std::hypot(fu, fv)));
      if (radius <= 0 || radius >= n / 2) continue;
      const cv::Vec2f c = spectrum.at<cv::Vec2f>(v, u);
      power[radius] += static_cast<double>(c[0]) * c[0] + static_cast<double>(c[1]) * c[1];
      count[radius] += 1.0;
    }
  }
  double sx = 0, sy = 0, sxx = 0, sxy = 0, m = 0;
  for (int radius = static_cast<int>(0.02 * n + 0.5); radius <= static_cast<int>(0.25 * n); ++radius) {
    if (count[radius] <= 0.0 || power[radius] <= 0.0) continue;
    const double x = std::log(radius / static_cast<double>(n)), y = std::log(power[radius] / count[radius]);
    sx += x, sy += y, sxx += x * x, sxy += x * y, m += 1.0;
  }
  return (m * sxy - sx * sy) / (m * sxx - sx * sx);
}

void AccumulateTexture(const cv::Mat& grey, const cv::Mat& image, const cv::Mat& valid, CameraStats* s) {
  cv::Mat eigen, gx, gy, gradient;
  cv::cornerMinEigenVal(image, eigen, 3, 3);
  cv::Sobel(image, gx, CV_32F, 1, 0, 3, 1.0 / 8.0);
  cv::Sobel(image, gy, CV_32F, 0, 1, 3, 1.0 / 8.0);
  cv::magnitude(gx, gy, gradient);
  for (int y = 1; y + 1 < image.rows; ++y) {
    const uint8_t* ok = valid.ptr<uint8_t>(y);
    const float* e = eigen.ptr<float>(y);
    const float* g = gradient.ptr<float>(y);
    for (int x = 1; x + 1 < image.cols; ++x) {
      if (ok[x] == 0) continue;
      const double level = std::log10(std::max(1e-4, static_cast<double>(e[x])));
      s->eigen_hist[std::clamp(static_cast<int>((level + 4.0) * 100.0), 0, kEigenBins - 1)] += 1.0;
      s->gradient_over_4 += g[x] > 4.0f ? 1.0 : 0.0;
      s->gradient_over_16 += g[x] > 16.0f ? 1.0 : 0.0;
      s->valid_pixels += 1.0;
    }
  }
  std::vector<cv::KeyPoint> corners;
  cv::FAST(grey, corners, 20, true);
  for (const cv::KeyPoint& k : corners) {
    s->fast_corners += valid.at<uint8_t>(cvRound(k.pt.y), cvRound(k.pt.x)) != 0 ? 1.0 : 0.0;
  }
  const double slope = SpectrumSlope(image);
  if (std::isfinite(slope)) s->spectrum_slope_sum += slope, ++s->spectrum_frames;
}

void AccumulateBlockiness(const cv::Mat& grey, const cv::Mat& valid, CameraStats* s) {
  for (int y = 0; y < grey.rows; ++y) {
    const uint8_t* g = grey.ptr<uint8_t>(y);
    const uint8_t* ok = valid.ptr<uint8_t>(y);
    const uint8_t* g_next = y + 1 < grey.rows ? grey.ptr<uint8_t>(y + 1) : nullptr;
    const uint8_t* ok_next = y + 1 < grey.rows ? valid.ptr<uint8_t>(y + 1) : nullptr;
    for (int x = 0; x < grey.cols; ++x) {
      if (ok[x] == 0) continue;
      if (x + 1 < grey.cols && ok[x + 1] != 0) {
        s->diff_x[x % 8] += std::abs(int{g[x + 1]} - int{g[x]});
        s->count_x[x % 8] += 1.0;
      }
      if (g_next != nullptr && ok_next[x] != 0) {
        s->diff_y[y % 8] += std::abs(int{g_next[x]} - int{g[x]});
        s->count_y[y % 8] += 1.0;
      }
    }
  }
}

void AccumulateFrame(const cv::Mat& grey, const cv::Mat& valid, bool temporal, CameraStats* s) {
  cv::Mat image;
  grey.convertTo(image, CV_32F);
  AccumulateNoise(image, valid, &s->noise);
  CollectEdgeRatios(image, valid, &s->edge_ratios);
  CollectEdgeRatios(image.t(), valid.t(), &s->edge_ratios);
  AccumulateTexture(grey, image, valid, s);
  AccumulateBlockiness(grey, valid, s);
  cv::Mat d;
  image.convertTo(d, CV_64F);
  if (s->sum.empty())
    s->sum = cv::Mat::zeros(grey.size(), CV_64F), s->diff_sq = cv::Mat::zeros(grey.size(), CV_64F);
  s->sum += d;
  if (temporal && !s->previous.empty()) {
    const cv::Mat step = d - s->previous;
    s->diff_sq += step.mul(step);
  }
  if (temporal) s->previous = d;
  cv::Scalar mean, std;
  cv::meanStdDev(grey, mean, std, valid);
  s->frame_std_sum += std[0];
  for (int y = 0; y < grey.rows; ++y) {
    for (int x = 0; x < grey.cols; ++x) {
      if (valid.at<uint8_t>(y, x) != 0) s->histogram[grey.at<uint8_t>(y, x)] += 1.0;
    }
  }
  ++s->frames;
}

nlohmann::ordered_json TemporalJson(CameraStats* s, const cv::Mat& valid) {
  const double n = s->frames;
  cv::Mat mean = s->sum / n;
  // var = E[(I_t+1 - I_t)^2] / 2: the static scene and slow drifts cancel.
  cv::Mat variance = s->diff_sq / (2.0 * std::max(1.0, n - 1.0));
  cv::Mat mean_f;
  mean.convertTo(mean_f, CV_32F);
  const auto bins = FlattestBlocks(mean_f, valid);
  for (int bin = 0; bin < kBins; ++bin) {
    for (const Block& block : bins[bin]) {
      const cv::Rect rect(block.x, block.y, kBlock, kBlock);
      s->temporal.variance_sum[bin] += cv::sum(variance(rect))[0];
      s->temporal.brightness_sum[bin] += block.mean * kBlock * kBlock;
      s->temporal.pixels[bin] += kBlock * kBlock;
    }
  }
  return NoiseJson(s->temporal, true);
}

nlohmann::ordered_json VignettingJson(const CameraStats& s, const cv::Mat& valid) {
  std::array<double, kRadiusBins> sum{}, count{};
  const double cx = 0.5 * (valid.cols - 1), cy = 0.5 * (valid.rows - 1), r_max = std::hypot(cx, cy);
  for (int y = 0; y < valid.rows; ++y) {
    for (int x = 0; x < valid.cols; ++x) {
      if (valid.at<uint8_t>(y, x) == 0) continue;
      const int bin =
          std::min(kRadiusBins - 1, static_cast<int>(kRadiusBins * std::hypot(x - cx, y - cy) / r_max));
      sum[bin] += s.sum.at<double>(y, x) / s.frames;
      count[bin] += 1.0;
    }
  }
  nlohmann::ordered_json relative = nlohmann::ordered_json::array();
  for (int bin = 0; bin < kRadiusBins; ++bin) {
    if (count[bin] > 0.0 && count[0] > 0.0) {
      relative.push_back((sum[bin] / count[bin]) / (sum[0] / count[0]));
    } else {
      relative.push_back(nullptr);
    }
  }
  return {{"radius_bins", kRadiusBins}, {"relative_mean", relative}};
}

nlohmann::ordered_json ExposureJson(const CameraStats& s) {
  std::vector<double> hist(s.histogram.begin(), s.histogram.end());
  double total = 0.0, mean = 0.0;
  for (int i = 0; i < 256; ++i) total += hist[i], mean += i * hist[i];
  nlohmann::ordered_json j;
  for (int p : {1, 5, 50, 95, 99}) j["p" + std::to_string(p)] = HistogramQuantile(hist, p / 100.0);
  j["fraction_0"] = hist[0] / total;
  j["fraction_255"] = hist[255] / total;
  j["mean"] = mean / total;
  j["frame_std"] = s.frame_std_sum / s.frames;
  j["histogram"] = hist;
  return j;
}

nlohmann::ordered_json TextureJson(const CameraStats& s) {
  const double median = HistogramQuantile(s.eigen_hist, 0.5), p90 = HistogramQuantile(s.eigen_hist, 0.9);
  return {{"min_eigen_median", std::pow(10.0, median / 100.0 - 4.0)},
          {"min_eigen_p90", std::pow(10.0, p90 / 100.0 - 4.0)},
          {"gradient_over_4", s.gradient_over_4 / s.valid_pixels},
          {"gradient_over_16", s.gradient_over_16 / s.valid_pixels},
          {"fast20_per_10k_px", 1e4 * s.fast_corners / s.valid_pixels},
          {"spectrum_slope", s.spectrum_frames > 0 ? s.spectrum_slope_sum / s.spectrum_frames : 0.0}};
}

nlohmann::ordered_json BlockinessJson(const CameraStats& s) {
  nlohmann::ordered_json j;
  auto axis = [](const std::array<double, 8>& diff, const std::array<double, 8>& count) {
    std::array<double, 8> mean{};
    for (int p = 0; p < 8; ++p) mean[p] = count[p] > 0.0 ? diff[p] / count[p] : 0.0;
    auto ratio = [&mean](int p) {
      double others = 0.0;
      for (int q = 0; q < 8; ++q) others += q == p ? 0.0 : mean[q] / 7.0;
      return others > 0.0 ? mean[p] / others : 0.0;
    };
    double best = 0.0;
    for (int p = 0; p < 8; ++p) best = std::max(best, ratio(p));
    return nlohmann::ordered_json{{"grid_ratio", ratio(7)}, {"max_phase_ratio", best}};
  };
  j["across_columns"] = axis(s.diff_x, s.count_x);
  j["across_rows"] = axis(s.diff_y, s.count_y);
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  mcvo::DatasetOptions options;
  int max_frames = 0;
  bool temporal = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--format" && i + 1 < argc) {
      options.format = argv[++i];
    } else if (arg == "--frames" && i + 1 < argc) {
      max_frames = std::atoi(argv[++i]);
    } else if (arg == "--flat-share" && i + 1 < argc) {
      g_flattest = std::clamp(std::atof(argv[++i]), 0.01, 1.0);
    } else if (arg == "--temporal") {
      temporal = true;
    } else if (options.root.empty() && arg.rfind("--", 0) != 0) {
      options.root = arg;
    } else {
      options.root.clear();
      break;
    }
  }
  if (options.root.empty()) {
    std::fprintf(
        stderr,
        "usage: mcvo_bench_image_stats DIR [--format F] [--frames N] [--temporal] [--flat-share X]\n");
    return 2;
  }
  mcvo::DatasetIndex index = mcvo::OpenDataset(options);
  const size_t total = index.frames.size();
  if (max_frames > 0 && static_cast<size_t>(max_frames) < total) {
    std::vector<mcvo::DatasetFrame> chosen;
    for (int k = 0; k < max_frames; ++k) chosen.push_back(index.frames[k * total / max_frames]);
    index.frames = chosen;
  }
  const int cameras = index.rig.NumCameras();
  std::vector<CameraStats> stats(cameras);
  std::vector<cv::Mat> valid(cameras);
  mcvo::FrameStream stream(index, {1, 4, false});
  while (std::optional<mcvo::FrameImages> frame = stream.Next()) {
    for (int c = 0; c < cameras; ++c) {
      const cv::Mat& grey = frame->images[c];
      if (grey.empty()) continue;
      if (valid[c].empty())
        valid[c] =
            ValidMask(c < static_cast<int>(index.masks.size()) ? index.masks[c] : cv::Mat(), grey.size());
      AccumulateFrame(grey, valid[c], temporal, &stats[c]);
    }
  }
  nlohmann::ordered_json out;
  out["dataset"] = options.root.string();
  out["format"] = index.format;
  out["frames_measured"] = index.frames.size();
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (int c = 0; c < cameras; ++c) {
    CameraStats& s = stats[c];
    if (s.frames == 0) continue;
    const mcvo::Camera& camera = index.rig.cameras[c];
    nlohmann::ordered_json j;
    j["name"] = camera.name;
    j["width"] = valid[c].cols;
    j["height"] = valid[c].rows;
    j["frames"] = s.frames;
    j["noise"] = NoiseJson(s.noise, false);
    if (temporal) j["temporal_noise"] = TemporalJson(&s, valid[c]);
    j["sharpness"] = SharpnessJson(s.edge_ratios);
    j["vignetting"] = VignettingJson(s, valid[c]);
    j["exposure"] = ExposureJson(s);
    j["texture"] = TextureJson(s);
    j["compression"] = BlockinessJson(s);
    list.push_back(j);
  }
  out["cameras"] = list;
  std::printf("%s\n", out.dump(2).c_str());
  return 0;
}
