// Building materials: plaster and brick facades with a grid of windows per
// floor, shop fronts, posters. See texture.cc for the band-limiting rule.
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
using noise::PulseAverageClipped;
using noise::SubSeed;

// Windows: `columns` per floor at `pitch`, centred on the quad; floor k has
// its window from k floor_height + sill up `height`; floors are counted from
// v = 0 while a whole window (plus 0.2 m) fits below the top edge.
struct WindowGrid {
  double floor_height;
  double pitch;
  double width;
  double height;
  double sill;
  double frame;
  double mullion;     // 0: none
  double transom;     // 0: none
  double transom_at;  // above the bottom of the glass
  double u0;          // left edge of the first window
  int columns;
  int floors;
  double frame_albedo;
};

constexpr double kSillDepth = 0.06;     // height of the sill ledge below the window
constexpr double kSillOverhang = 0.07;  // sideways, each side
constexpr double kReveal = 0.09;        // shadowed reveal of the opening, top and left

WindowGrid MakeWindowGrid(uint32_t seed, double extent_u, double extent_v) {
  WindowGrid g{};
  g.floor_height = Draw(seed, 20, 3.0, 3.5);
  g.pitch = Draw(seed, 21, 2.4, 4.0);
  g.width = Draw(seed, 22, 0.9, std::min(1.8, g.pitch - 0.8));
  g.height = Draw(seed, 23, 1.3, 1.9);
  g.sill = Draw(seed, 24, 0.8, 1.0);
  g.frame = Draw(seed, 25, 0.05, 0.09);
  g.mullion = g.width > 1.15 ? 0.05 : 0.0;
  g.transom = Draw(seed, 26) < 0.5 ? 0.05 : 0.0;
  g.transom_at = 0.62 * (g.height - 2.0 * g.frame);
  g.frame_albedo = Draw(seed, 27) < 0.6 ? 0.85 : 0.12;
  const double usable = extent_u - 0.8 - g.width;
  g.columns = usable >= 0.0 ? 1 + static_cast<int>(usable / g.pitch) : 0;
  g.u0 = 0.5 * (extent_u - ((g.columns - 1) * g.pitch + g.width));
  g.floors = static_cast<int>(std::max(0.0, (extent_v - g.sill - g.height - 0.2) / g.floor_height + 1.0));
  if (g.columns == 0) g.floors = 0;
  return g;
}

// What is behind one window's glass (dark glass, blinds or curtains), box
// filtered, before reflections.
double GlassContent(const WindowGrid& g, const Query& q, int64_t column, int64_t floor, uint32_t seed) {
  const uint32_t h = noise::HashLattice(column, floor, SubSeed(seed, 30));
  double content = 0.08 + 0.22 * noise::Unit(h);
  const double left = g.u0 + static_cast<double>(column) * g.pitch + g.frame;
  const double right = left + g.width - 2.0 * g.frame;
  const double top = static_cast<double>(floor) * g.floor_height + g.sill + g.height - g.frame;
  const uint32_t type = (h >> 4) & 7U;
  if (type < 3) {  // blinds lowered over the top part: horizontal slats, 3 cm pitch
    const double drop = (0.2 + 0.8 * noise::Unit(noise::Mix(h))) * (g.height - 2.0 * g.frame);
    const double slats = noise::PulseAverage(q.v, q.f, 0.03, 0.024, 0.0);
    content = Lerp(content, Lerp(0.2, 0.6, slats), IntervalAverage(q.v, q.f, top - drop, top));
  } else if (type < 5) {  // curtains drawn to the sides, with folds
    const double band = 0.2 * (right - left);
    const double folds = 0.5 + 0.1 * noise::OctaveWeight(0.09, 1.5 * q.f) * std::sin(q.u * 69.8131700797731);
    const double cover =
        IntervalAverage(q.u, q.f, left, left + band) + IntervalAverage(q.u, q.f, right - band, right);
    content = Lerp(content, folds, cover);
  }
  return content;
}

// Sum over the windows in the footprint of (its glass coverage) x (its
// content). Cells of pitch x floor height, with boundaries in the wall
// between windows, hold one window each; a footprint up to one cell wide
// overlaps at most 2 x 2 of them, and each window's glass coverage is exact
// (separable intervals), so the sum is exact there. Wider footprints fade
// to (total glass coverage) x (mean content).
double WindowContents(const WindowGrid& g, const Query& q, double glass, uint32_t seed) {
  constexpr double kMeanContent = 0.27;
  const double cell = std::min(g.pitch, g.floor_height);
  const double fade = noise::Smoothstep(cell, 2.0 * cell, q.f);
  if (fade >= 1.0) return glass * kMeanContent;
  const noise::CellSpan cu = noise::SpanCells(q.u, q.f, g.pitch, g.u0 + 0.5 * (g.width - g.pitch));
  const noise::CellSpan cv = noise::SpanCells(q.v, q.f, g.floor_height, 0.0);
  const double glass_width = g.width - 2.0 * g.frame;
  const double glass_height = g.height - 2.0 * g.frame;
  double sum = 0.0;
  for (int64_t column = cu.cell; column <= cu.cell + 1; ++column) {
    if (column < 0 || column >= g.columns) continue;
    const double left = g.u0 + static_cast<double>(column) * g.pitch + g.frame;
    double cover_u = IntervalAverage(q.u, q.f, left, left + glass_width);
    if (g.mullion > 0.0) {
      const double mid = left + 0.5 * glass_width;
      cover_u -= IntervalAverage(q.u, q.f, mid - 0.5 * g.mullion, mid + 0.5 * g.mullion);
    }
    if (cover_u <= 0.0) continue;
    for (int64_t floor = cv.cell; floor <= cv.cell + 1; ++floor) {
      if (floor < 0 || floor >= g.floors) continue;
      const double bottom = static_cast<double>(floor) * g.floor_height + g.sill + g.frame;
      double cover_v = IntervalAverage(q.v, q.f, bottom, bottom + glass_height);
      if (g.transom > 0.0) {
        cover_v -= IntervalAverage(q.v, q.f, bottom + g.transom_at, bottom + g.transom_at + g.transom);
      }
      if (cover_v <= 0.0) continue;
      sum += cover_u * cover_v * GlassContent(g, q, column, floor, seed);
    }
  }
  return Lerp(sum, glass * kMeanContent, fade);
}

// Composites the window grid over a wall albedo.
double WithWindows(const WindowGrid& g, const Query& q, double wall, uint32_t seed) {
  if (g.columns == 0 || g.floors == 0) return wall;
  // Quick exit (most wall samples): the footprint misses, in u or in v, the
  // periodic boxes that hold everything a window draws (reveal, sill).
  const auto misses = [](double x, double f, double period, double lo, double hi) {
    if (f >= period - (hi - lo)) return false;
    const double r = x - lo - std::floor((x - lo) / period) * period;
    return r - 0.5 * f > hi - lo && r + 0.5 * f < period;
  };
  const double reach = std::max(kReveal, kSillOverhang);
  if (misses(q.u, q.f, g.pitch, g.u0 - reach, g.u0 + g.width + reach) ||
      misses(q.v, q.f, g.floor_height, g.sill - kSillDepth, g.sill + g.height + kReveal)) {
    return wall;
  }
  const double u_hi = g.u0 + (g.columns - 1) * g.pitch + g.width;
  const double v_hi = g.floors * g.floor_height;
  const double fr = g.frame;
  const auto along_u = [&](double width, double offset, double lo, double hi) {
    return PulseAverageClipped(q.u, q.f, g.pitch, width, g.u0 + offset, g.u0 + lo, hi);
  };
  const auto along_v = [&](double height, double offset) {
    return PulseAverageClipped(q.v, q.f, g.floor_height, height, offset, 0.0, v_hi);
  };
  // Separable rectangles, exact per axis; nested ones by inclusion-exclusion.
  const double opening_u = along_u(g.width, 0.0, 0.0, u_hi);
  const double opening_v = along_v(g.height, g.sill);
  const double opening = opening_u * opening_v;
  const double glass_u = along_u(g.width - 2.0 * fr, fr, 0.0, u_hi) -
                         (g.mullion > 0.0 ? along_u(g.mullion, 0.5 * (g.width - g.mullion), 0.0, u_hi) : 0.0);
  const double glass_v = along_v(g.height - 2.0 * fr, g.sill + fr) -
                         (g.transom > 0.0 ? along_v(g.transom, g.sill + fr + g.transom_at) : 0.0);
  const double glass = glass_u * glass_v;
  const double reveal =
      along_u(g.width + kReveal, -kReveal, -kReveal, u_hi) * along_v(g.height + kReveal, g.sill) - opening;
  const double sill =
      along_u(g.width + 2.0 * kSillOverhang, -kSillOverhang, -kSillOverhang, u_hi + kSillOverhang) *
      along_v(kSillDepth, g.sill - kSillDepth);
  double value =
      wall * (1.0 - opening - 0.45 * reveal - sill) + g.frame_albedo * (opening - glass) + 0.72 * sill;
  if (glass > 0.0) {
    const double reflections = 0.09 * Fbm(q.u, q.v, q.f, SubSeed(seed, 31), 2.5, 0.05, 0.55);
    value += glass * reflections + WindowContents(g, q, glass, seed);
  }
  return value;
}

// Letter-like glyphs: 5 x 7 bits of side b in cells of 6 x 9 bits; a glyph
// is a union of strokes (vertical at bit columns 0, 2, 4; horizontal at bit
// rows 0, 3, 6), 15% of glyphs are spaces. A mip chain of three levels, each
// box-filtered over the (at most 2 x 2) cells the footprint overlaps:
// bits (exact while f <= b), per-glyph ink density (f from b to 2b), and
// the block's mean density (f from 6b to 12b).
bool GlyphIsSpace(uint32_t h) { return (h & 0xffU) < 38U; }
int GlyphStrokes(uint32_t h, int first) {
  return static_cast<int>((h >> first) & 1U) + static_cast<int>((h >> (first + 1)) & 1U) +
         static_cast<int>((h >> (first + 2)) & 1U);
}

double TextCoverage(const Query& q, double b, double u_lo, double v_lo, int columns, int rows,
                    uint32_t seed) {
  const double block = IntervalAverage(q.u, q.f, u_lo, u_lo + columns * 6 * b) *
                       IntervalAverage(q.v, q.f, v_lo, v_lo + rows * 9 * b);
  if (block <= 0.0) return 0.0;
  // E[ink] per cell: 0.85 x (7 E[v] + 5 E[h] - E[v] E[h]) / 54 with E[v] = E[h] = 1.5.
  constexpr double kMeanInk = 0.85 * (7.0 * 1.5 + 5.0 * 1.5 - 2.25) / 54.0;
  const double to_mean = noise::Smoothstep(6.0 * b, 12.0 * b, q.f);
  if (to_mean >= 1.0) return kMeanInk * block;
  const auto glyph_hash = [&](int64_t gx, int64_t gy) { return noise::HashLattice(gx, gy, seed); };
  const auto in_block = [&](int64_t gx, int64_t gy) {
    return gx >= 0 && gy >= 0 && gx < columns && gy < rows;
  };
  const auto bit = [&](int64_t ix, int64_t iy) -> double {
    const int64_t gx = ix >= 0 ? ix / 6 : -1;
    const int64_t gy = iy >= 0 ? iy / 9 : -1;
    if (!in_block(gx, gy)) return 0.0;
    const int64_t bx = ix % 6;
    const int64_t by = iy % 9;
    if (bx == 5 || by >= 7) return 0.0;
    const uint32_t h = glyph_hash(gx, gy);
    if (GlyphIsSpace(h)) return 0.0;
    const bool vertical = bx % 2 == 0 && ((h >> (8 + bx / 2)) & 1U) != 0U;
    const bool horizontal = by % 3 == 0 && ((h >> (11 + by / 3)) & 1U) != 0U;
    return vertical || horizontal ? 1.0 : 0.0;
  };
  const auto density = [&](int64_t gx, int64_t gy) -> double {
    if (!in_block(gx, gy)) return 0.0;
    const uint32_t h = glyph_hash(gx, gy);
    if (GlyphIsSpace(h)) return 0.0;
    const int v = GlyphStrokes(h, 8);
    const int hz = GlyphStrokes(h, 11);
    return (7.0 * v + 5.0 * hz - v * hz) / 54.0;
  };
  const auto blend = [&](double cell_u, double cell_v, const auto& value) {
    const noise::CellSpan cu = noise::SpanCells(q.u, q.f, cell_u, u_lo);
    const noise::CellSpan cv = noise::SpanCells(q.v, q.f, cell_v, v_lo);
    return cv.w0 * (cu.w0 * value(cu.cell, cv.cell) + (1.0 - cu.w0) * value(cu.cell + 1, cv.cell)) +
           (1.0 - cv.w0) *
               (cu.w0 * value(cu.cell, cv.cell + 1) + (1.0 - cu.w0) * value(cu.cell + 1, cv.cell + 1));
  };
  const double to_glyphs = noise::Smoothstep(b, 2.0 * b, q.f);
  double ink = to_glyphs < 1.0 ? blend(b, b, bit) : 0.0;
  if (to_glyphs > 0.0) ink = Lerp(ink, blend(6.0 * b, 9.0 * b, density), to_glyphs);
  return Lerp(ink, kMeanInk * block, to_mean);
}

}  // namespace

double FacadePlaster(const Query& q) {
  const WindowGrid g = MakeWindowGrid(q.seed, q.extent_u, q.extent_v);
  double wall = Draw(q.seed, 0, 0.4, 0.7);
  wall += 0.06 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 1), 6.0, 0.2, 0.5);          // stains
  wall += 0.025 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 2), 0.08, 0.001, 0.7);      // plaster grain
  wall += 0.012 * Fbm(q.v, q.u, q.f, SubSeed(q.seed, 3), 0.1, 0.02, 0.5, 15.0);  // rain streaks, along v
  if (Draw(q.seed, 4) < 0.7) {  // cornice at each floor line: light band over a shadow
    const double hi = g.floors * g.floor_height + 0.2;
    const double band = PulseAverageClipped(q.v, q.f, g.floor_height, 0.2, -0.1, 0.5, hi);
    const double shadow = PulseAverageClipped(q.v, q.f, g.floor_height, 0.05, -0.15, 0.5, hi);
    wall += 0.12 * band - 0.15 * shadow;
  }
  wall -= 0.1 * IntervalAverage(q.v, q.f, -1.0, 0.4);  // plinth
  return WithWindows(g, q, wall, q.seed);
}

double FacadeBrick(const Query& q) {
  const WindowGrid g = MakeWindowGrid(q.seed, q.extent_u, q.extent_v);
  const Bond bond{Draw(q.seed, 0, 0.21, 0.3), Draw(q.seed, 1, 0.065, 0.09), Draw(q.seed, 2, 0.008, 0.013),
                  0.5};
  double brick = Draw(q.seed, 3, 0.25, 0.45) + 0.08 * UnitTone(bond, q.u, q.v, q.f, SubSeed(q.seed, 4));
  brick += 0.03 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 5), 0.05, 0.001, 0.7);
  const double mortar = Draw(q.seed, 6) < 0.8 ? Draw(q.seed, 7, 0.5, 0.7) : 0.18;
  double wall = Lerp(brick, mortar, JointCoverage(bond, q.u, q.v, q.f));
  wall += 0.06 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 8), 6.0, 0.25, 0.5);  // weathering
  return WithWindows(g, q, wall, q.seed);
}

namespace {

// Ground floor with shops: bays of pitch 3.5-6 m separated by pillars; each
// bay spans [k pitch + pillar, (k + 1) pitch) and holds a framed display
// window (v 0.5-2.7 m; dark glass with reflections, often a poster inside)
// and a sign band with lettering (v 2.85-3.5 m).
struct ShopLayout {
  double pitch;
  double pillar;
  double sign_top;
};
constexpr double kShopFrame = 0.06;

// One bay's contribution: sum of (coverage x albedo) of its window frame,
// glass and sign, all box-filtered exactly against the bay's own intervals.
double BayContribution(const ShopLayout& s, const Query& q, int64_t bay) {
  const double left = static_cast<double>(bay) * s.pitch + s.pillar;
  const double right = static_cast<double>(bay + 1) * s.pitch;
  const double span_u = IntervalAverage(q.u, q.f, left, right);
  if (span_u <= 0.0) return 0.0;
  const uint32_t h = noise::HashLattice(bay, 0, SubSeed(q.seed, 4));
  const double window = span_u * IntervalAverage(q.v, q.f, 0.5, 2.7);
  const double pane = IntervalAverage(q.u, q.f, left + kShopFrame, right - kShopFrame) *
                      IntervalAverage(q.v, q.f, 0.5 + kShopFrame, 2.7 - kShopFrame);
  const double sign = span_u * IntervalAverage(q.v, q.f, 2.85, std::max(2.85, s.sign_top));
  double sum = 0.15 * (window - pane);
  if (pane > 0.0) {
    double glass = 0.15 + 0.1 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 5), 3.0, 0.05, 0.55);
    if ((h & 7U) < 5U) {  // a poster or goods display inside
      const double poster_w = std::min(1.4, right - left - 0.4);
      const double p_left = left + 0.2 + (right - left - 0.4 - poster_w) * noise::Unit(noise::Mix(h));
      const Query local{q.u - p_left, q.v - 0.9, q.f, poster_w, 1.6, h};
      const double in_poster =
          IntervalAverage(local.u, q.f, 0.0, poster_w) * IntervalAverage(local.v, q.f, 0.0, 1.6);
      if (in_poster > 0.0) glass = Lerp(glass, Poster(local) * 0.8 + 0.02, in_poster);
    }
    sum += glass * pane;
  }
  if (sign > 0.0) {
    const double tone = 0.1 + 0.8 * noise::Unit(noise::Mix(h + 1));
    const int letters = std::max(0, static_cast<int>((right - left - 0.6) / 0.24));
    const double ink = TextCoverage(q, 0.04, left + 0.3, 2.95, letters, 1, h);
    sum += sign * Lerp(tone, tone > 0.5 ? 0.08 : 0.95, ink);
  }
  return sum;
}

}  // namespace

// Bays are cells of the pitch with boundaries mid-pillar: a footprint up to
// a pitch wide overlaps at most two, and their contributions are exact; wider
// footprints fade to (coverage of the bay areas) x (mean bay albedo).
double ShopFront(const Query& q) {
  const ShopLayout s{Draw(q.seed, 0, 3.5, 6.0), Draw(q.seed, 1, 0.3, 0.6), std::min(q.extent_v - 0.1, 3.5)};
  const double wall =
      Draw(q.seed, 2, 0.3, 0.6) + 0.05 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 3), 4.0, 0.002, 0.55);
  const double span_u = noise::PulseAverage(q.u, q.f, s.pitch, s.pitch - s.pillar, s.pillar);
  const double cover = span_u * (IntervalAverage(q.v, q.f, 0.5, 2.7) +
                                 IntervalAverage(q.v, q.f, 2.85, std::max(2.85, s.sign_top)));
  if (cover <= 0.0) return wall;
  constexpr double kMeanBay = 0.3;
  const double fade = noise::Smoothstep(s.pitch, 2.0 * s.pitch, q.f);
  double bays = cover * kMeanBay;
  if (fade < 1.0) {
    const noise::CellSpan cells = noise::SpanCells(q.u, q.f, s.pitch, 0.5 * s.pillar);
    const double exact = BayContribution(s, q, cells.cell) + BayContribution(s, q, cells.cell + 1);
    bays = Lerp(exact, bays, fade);
  }
  return wall * (1.0 - cover) + bays;
}

// Unique high-contrast content per seed: a graffiti-like blob layer over a
// soft gradient, framed and outlined rectangles, discs, lines of lettering,
// a white border. Layout is relative to the quad.
double Poster(const Query& q) {
  const double eu = q.extent_u;
  const double ev = q.extent_v;
  const double s = std::min(eu, ev);
  double value = Draw(q.seed, 0, 0.2, 0.8) + 0.2 * (q.v / ev - 0.5);
  // Blobs: level set of two noise octaves.
  const double lambda = 0.3 * s;
  const uint32_t blob_seed = SubSeed(q.seed, 1);
  const double n =
      0.894 * (noise::GradientNoise(q.u / lambda, q.v / lambda, blob_seed) +
               0.5 * noise::GradientNoise(2.0 * q.u / lambda + 3.1, 2.0 * q.v / lambda + 7.7, blob_seed + 1));
  value = Lerp(value, Draw(q.seed, 2, 0.03, 0.97),
               noise::ThresholdCoverage(n, 0.4, lambda, q.f, noise::TailProbability(0.4)));
  // Rectangles (some as outlines) and discs, painted in order.
  for (uint32_t i = 0; i < 7; ++i) {
    const uint32_t k = 10 + 8 * i;
    const double cu = Draw(q.seed, k) * eu;
    const double cv = Draw(q.seed, k + 1) * ev;
    const double hu = Draw(q.seed, k + 2, 0.04, 0.25) * s;
    const double hv = Draw(q.seed, k + 3, 0.04, 0.25) * s;
    double cover = IntervalAverage(q.u, q.f, cu - hu, cu + hu) * IntervalAverage(q.v, q.f, cv - hv, cv + hv);
    if (Draw(q.seed, k + 4) < 0.3 && cover > 0.0) {  // outline: minus the inner rectangle
      const double t = 0.2 * std::min(hu, hv);
      cover -= IntervalAverage(q.u, q.f, cu - hu + t, cu + hu - t) *
               IntervalAverage(q.v, q.f, cv - hv + t, cv + hv - t);
    }
    value = Lerp(value, Draw(q.seed, k + 5, 0.03, 0.97), cover);
  }
  for (uint32_t i = 0; i < 4; ++i) {
    const uint32_t k = 80 + 4 * i;
    const double r = Draw(q.seed, k + 2, 0.03, 0.15) * s;
    const double cover =
        noise::DotCoverage(q.u - Draw(q.seed, k) * eu, q.v - Draw(q.seed, k + 1) * ev, r, q.f);
    value = Lerp(value, Draw(q.seed, k + 3, 0.03, 0.97), cover);
  }
  for (uint32_t i = 0; i < 2; ++i) {
    const uint32_t k = 100 + 4 * i;
    const double b = Draw(q.seed, k, 0.006, 0.018) * s;
    const int columns = std::max(1, static_cast<int>(Draw(q.seed, k + 1, 0.4, 0.9) * eu / (6.0 * b)));
    const int rows = 1 + static_cast<int>(Draw(q.seed, k + 2, 0.0, 3.0));
    const double v_lo = Draw(q.seed, k + 3, 0.05, 0.9) * ev;
    const double ink = TextCoverage(q, b, 0.06 * eu, v_lo, columns, rows, SubSeed(q.seed, k));
    value = Lerp(value, i == 0 ? 0.05 : 0.95, ink);
  }
  value += 0.015 * Fbm(q.u, q.v, q.f, SubSeed(q.seed, 3), 0.02, 0.001, 0.7);  // paper
  const double border = 0.03 * s;
  const double inside =
      IntervalAverage(q.u, q.f, border, eu - border) * IntervalAverage(q.v, q.f, border, ev - border);
  return Lerp(0.9, value, inside);
}

}  // namespace mcvo::synth::texture
