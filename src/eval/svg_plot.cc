#include "svg_plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "mcvo/util/strings.h"

namespace mcvo::report_internal {
namespace {

constexpr const char* kFont = "font-family=\"sans-serif\"";

// Distance from p to the segment [a, b].
double SegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double length2 = ab.squaredNorm();
  if (length2 <= 0.0) return (p - a).norm();
  const double t = std::clamp((p - a).dot(ab) / length2, 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

// Ramer-Douglas-Peucker, iterative (no recursion depth limit).
std::vector<Eigen::Vector2d> Rdp(const std::vector<Eigen::Vector2d>& points, double tolerance) {
  const size_t n = points.size();
  if (n <= 2) return points;
  std::vector<char> keep(n, 0);
  keep[0] = keep[n - 1] = 1;
  std::vector<std::pair<size_t, size_t>> stack = {{0, n - 1}};
  while (!stack.empty()) {
    const auto [first, last] = stack.back();
    stack.pop_back();
    double best = -1.0;
    size_t best_index = first;
    for (size_t i = first + 1; i < last; ++i) {
      const double d = SegmentDistance(points[i], points[first], points[last]);
      if (d > best) {
        best = d;
        best_index = i;
      }
    }
    if (best > tolerance) {
      keep[best_index] = 1;
      stack.emplace_back(first, best_index);
      stack.emplace_back(best_index, last);
    }
  }
  std::vector<Eigen::Vector2d> out;
  for (size_t i = 0; i < n; ++i) {
    if (keep[i]) out.push_back(points[i]);
  }
  return out;
}

// out += a; out += b; ... without temporaries.
template <typename... Parts>
void Append(std::string* out, const Parts&... parts) {
  ((*out += parts), ...);
}

std::string DashAttribute(bool dashed) { return dashed ? " stroke-dasharray=\"6 4\"" : ""; }

}  // namespace

std::string Px(double value) { return FormatFixed(value, 1); }

std::string HtmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    switch (ch) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        if ((c < 0x20 && ch != '\t' && ch != '\n') || c == 0x7f) {
          out += "\xEF\xBF\xBD";  // U+FFFD
        } else {
          out += ch;
        }
    }
  }
  return out;
}

Ticks NiceTicks(double lo, double hi, int target) {
  Ticks ticks;
  if (!std::isfinite(lo) || !std::isfinite(hi)) return ticks;
  if (hi < lo) std::swap(lo, hi);
  const double range = hi > lo ? hi - lo : 1.0;
  const double raw = range / std::max(target, 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double normalized = raw / magnitude;
  const double factor = normalized < 1.5 ? 1.0 : normalized < 3.5 ? 2.0 : normalized < 7.5 ? 5.0 : 10.0;
  ticks.step = factor * magnitude;
  ticks.decimals = std::max(0, -static_cast<int>(std::floor(std::log10(ticks.step) + 1e-9)));
  const double first = std::ceil(lo / ticks.step - 1e-9);
  const double last = std::floor(hi / ticks.step + 1e-9);
  for (double k = first; k <= last && ticks.values.size() < 200; k += 1.0) {
    ticks.values.push_back(k * ticks.step);
  }
  return ticks;
}

std::vector<Eigen::Vector2d> DecimatePolyline(const std::vector<Eigen::Vector2d>& pixels, size_t max_points) {
  max_points = std::max<size_t>(max_points, 2);
  if (pixels.size() <= 2) return pixels;
  // 1. Points that do not move the pen by 0.1 px add nothing.
  std::vector<Eigen::Vector2d> kept = {pixels.front()};
  for (size_t i = 1; i + 1 < pixels.size(); ++i) {
    if ((pixels[i] - kept.back()).norm() >= 0.1) kept.push_back(pixels[i]);
  }
  kept.push_back(pixels.back());
  // 2. Bound the work of RDP (quadratic in the worst case) on huge inputs:
  //    per bucket of consecutive points, keep its first point and the one
  //    farthest from the chord to the next bucket (one level of RDP, so a
  //    spike survives).
  const size_t rdp_bound = 8 * max_points;
  if (kept.size() > rdp_bound) {
    const size_t bucket = (kept.size() + rdp_bound / 2 - 1) / (rdp_bound / 2);
    std::vector<Eigen::Vector2d> reduced;
    for (size_t start = 0; start + 1 < kept.size(); start += bucket) {
      const size_t end = std::min(start + bucket, kept.size() - 1);
      reduced.push_back(kept[start]);
      double best = -1.0;
      size_t best_index = start;
      for (size_t i = start + 1; i < end; ++i) {
        const double d = SegmentDistance(kept[i], kept[start], kept[end]);
        if (d > best) {
          best = d;
          best_index = i;
        }
      }
      if (best_index != start) reduced.push_back(kept[best_index]);
    }
    reduced.push_back(kept.back());
    kept = std::move(reduced);
  }
  // 3. RDP, coarser until it fits.
  double tolerance = 0.25;
  std::vector<Eigen::Vector2d> out = Rdp(kept, tolerance);
  while (out.size() > max_points) {
    tolerance *= 2.0;
    out = Rdp(kept, tolerance);
  }
  return out;
}

SvgPlot::SvgPlot(std::string id, double width, double height)
    : id_(std::move(id)), width_(width), height_(height) {}

void SvgPlot::SetMargins(double left, double right, double top, double bottom) {
  left_ = left;
  right_ = right;
  top_ = top;
  bottom_ = bottom;
}

void SvgPlot::SetRanges(double x_lo, double x_hi, double y_lo, double y_hi, bool equal_aspect) {
  // A degenerate range becomes one unit about its value.
  if (!(x_hi > x_lo)) {
    x_lo -= 0.5;
    x_hi = x_lo + 1.0;
  }
  if (!(y_hi > y_lo)) {
    y_lo -= 0.5;
    y_hi = y_lo + 1.0;
  }
  if (equal_aspect) {
    const double units_per_px = std::max((x_hi - x_lo) / PlotWidth(), (y_hi - y_lo) / PlotHeight());
    const double x_mid = 0.5 * (x_lo + x_hi), y_mid = 0.5 * (y_lo + y_hi);
    x_lo = x_mid - 0.5 * units_per_px * PlotWidth();
    x_hi = x_mid + 0.5 * units_per_px * PlotWidth();
    y_lo = y_mid - 0.5 * units_per_px * PlotHeight();
    y_hi = y_mid + 0.5 * units_per_px * PlotHeight();
  }
  x_lo_ = x_lo;
  x_hi_ = x_hi;
  y_lo_ = y_lo;
  y_hi_ = y_hi;
}

void SvgPlot::SetLabels(std::string x_label, std::string y_label) {
  x_label_ = std::move(x_label);
  y_label_ = std::move(y_label);
}

void SvgPlot::SetCategoricalX(std::vector<std::string> labels) {
  categories_ = std::move(labels);
  const double n = static_cast<double>(std::max<size_t>(categories_.size(), 1));
  x_lo_ = -0.5;
  x_hi_ = n - 0.5;
}

double SvgPlot::PixelX(double x) const { return left_ + (x - x_lo_) / (x_hi_ - x_lo_) * PlotWidth(); }
double SvgPlot::PixelY(double y) const { return top_ + (y_hi_ - y) / (y_hi_ - y_lo_) * PlotHeight(); }

void SvgPlot::AddPolyline(const std::vector<Eigen::Vector2d>& points, std::string_view css_class,
                          std::string_view colour, double stroke_width, bool dashed) {
  std::vector<std::vector<Eigen::Vector2d>> runs(1);
  for (const Eigen::Vector2d& p : points) {
    if (!p.allFinite()) {
      if (!runs.back().empty()) runs.emplace_back();
      continue;
    }
    runs.back().push_back(Pixel(p.x(), p.y()));
  }
  std::string d;
  for (const std::vector<Eigen::Vector2d>& run : runs) {
    const std::vector<Eigen::Vector2d> decimated = DecimatePolyline(run);
    for (size_t i = 0; i < decimated.size(); ++i) NoteSegment(decimated[i > 0 ? i - 1 : 0], decimated[i]);
    for (size_t i = 0; i < decimated.size(); ++i) {
      d += (i == 0 ? "M" : "L") + Px(decimated[i].x()) + "," + Px(decimated[i].y());
    }
    // A single point still shows as a dot (round caps).
    if (decimated.size() == 1) d += "h0";
  }
  if (d.empty()) return;
  content_ += "<path class=\"" + HtmlEscape(css_class) + "\" d=\"" + d + "\" fill=\"none\" stroke=\"" +
              HtmlEscape(colour) + "\" stroke-width=\"" + Px(stroke_width) +
              "\" stroke-linejoin=\"round\" stroke-linecap=\"round\"" + DashAttribute(dashed) + "/>\n";
}

void SvgPlot::NoteSegment(const Eigen::Vector2d& a_px, const Eigen::Vector2d& b_px) {
  const int steps = static_cast<int>(std::min(1000.0, std::ceil((b_px - a_px).norm() / 8.0)));
  for (int k = 0; k <= steps; ++k) {
    drawn_.push_back(steps == 0 ? b_px : a_px + (b_px - a_px) * (static_cast<double>(k) / steps));
  }
}

void SvgPlot::AddMarkers(const std::vector<Eigen::Vector2d>& points, std::string_view css_class,
                         std::string_view colour, double radius, bool filled) {
  for (const Eigen::Vector2d& p : points) {
    if (!p.allFinite()) continue;
    drawn_.push_back(Pixel(p.x(), p.y()));
    content_ += "<circle class=\"" + HtmlEscape(css_class) + "\" cx=\"" + Px(PixelX(p.x())) + "\" cy=\"" +
                Px(PixelY(p.y())) + "\" r=\"" + Px(radius) + "\" fill=\"" +
                (filled ? HtmlEscape(colour) : std::string("#ffffff")) + "\" stroke=\"" + HtmlEscape(colour) +
                "\" stroke-width=\"1.5\"/>\n";
  }
}

void SvgPlot::AddSquare(const Eigen::Vector2d& point, std::string_view css_class, std::string_view colour,
                        double half_size) {
  if (!point.allFinite()) return;
  content_ += "<rect class=\"" + HtmlEscape(css_class) + "\" x=\"" + Px(PixelX(point.x()) - half_size) +
              "\" y=\"" + Px(PixelY(point.y()) - half_size) + "\" width=\"" + Px(2 * half_size) +
              "\" height=\"" + Px(2 * half_size) + "\" fill=\"" + HtmlEscape(colour) +
              "\" stroke=\"#000000\" stroke-width=\"1\"/>\n";
}

void SvgPlot::AddVerticalLine(double x, std::string_view css_class, std::string_view colour, bool dashed,
                              std::string_view label) {
  if (!std::isfinite(x)) return;
  const std::string px = Px(PixelX(x));
  content_ += "<line class=\"" + HtmlEscape(css_class) + "\" x1=\"" + px + "\" y1=\"" + Px(top_) +
              "\" x2=\"" + px + "\" y2=\"" + Px(top_ + PlotHeight()) + "\" stroke=\"" + HtmlEscape(colour) +
              "\" stroke-width=\"1.2\"" + DashAttribute(dashed) + "/>\n";
  if (!label.empty()) {
    content_ += "<text x=\"" + Px(PixelX(x) + 3) + "\" y=\"" + Px(top_ + 11) + "\" " + kFont +
                " font-size=\"10\" fill=\"" + HtmlEscape(colour) + "\">" + HtmlEscape(label) + "</text>\n";
  }
}

void SvgPlot::AddHorizontalLine(double y, std::string_view css_class, std::string_view colour, bool dashed,
                                std::string_view label) {
  if (!std::isfinite(y)) return;
  const std::string py = Px(PixelY(y));
  content_ += "<line class=\"" + HtmlEscape(css_class) + "\" x1=\"" + Px(left_) + "\" y1=\"" + py +
              "\" x2=\"" + Px(left_ + PlotWidth()) + "\" y2=\"" + py + "\" stroke=\"" + HtmlEscape(colour) +
              "\" stroke-width=\"1.2\"" + DashAttribute(dashed) + "/>\n";
  if (!label.empty()) {
    content_ += "<text x=\"" + Px(left_ + 4) + "\" y=\"" + Px(PixelY(y) - 4) + "\" " + kFont +
                " font-size=\"10\" fill=\"" + HtmlEscape(colour) + "\">" + HtmlEscape(label) + "</text>\n";
  }
}

void SvgPlot::AddRect(double x0, double y0, double x1, double y1, std::string_view css_class,
                      std::string_view fill, std::string_view stroke, std::string_view tooltip) {
  const double px0 = std::min(PixelX(x0), PixelX(x1)), px1 = std::max(PixelX(x0), PixelX(x1));
  const double py0 = std::min(PixelY(y0), PixelY(y1)), py1 = std::max(PixelY(y0), PixelY(y1));
  if (!std::isfinite(px0 + px1 + py0 + py1)) return;
  for (double y = py0; y <= py1; y += 8.0) NoteSegment({px0, y}, {px1, y});
  NoteSegment({px0, py1}, {px1, py1});
  content_ += "<rect class=\"" + HtmlEscape(css_class) + "\" x=\"" + Px(px0) + "\" y=\"" + Px(py0) +
              "\" width=\"" + Px(px1 - px0) + "\" height=\"" + Px(std::max(py1 - py0, 1.0)) + "\" fill=\"" +
              HtmlEscape(fill) + "\" stroke=\"" + HtmlEscape(stroke) + "\" stroke-width=\"1\"";
  if (tooltip.empty()) {
    content_ += "/>\n";
  } else {
    content_ += "><title>" + HtmlEscape(tooltip) + "</title></rect>\n";
  }
}

void SvgPlot::AddSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, std::string_view css_class,
                         std::string_view colour, double stroke_width) {
  if (!a.allFinite() || !b.allFinite()) return;
  NoteSegment(Pixel(a.x(), a.y()), Pixel(b.x(), b.y()));
  content_ += "<line class=\"" + HtmlEscape(css_class) + "\" x1=\"" + Px(PixelX(a.x())) + "\" y1=\"" +
              Px(PixelY(a.y())) + "\" x2=\"" + Px(PixelX(b.x())) + "\" y2=\"" + Px(PixelY(b.y())) +
              "\" stroke=\"" + HtmlEscape(colour) + "\" stroke-width=\"" + Px(stroke_width) + "\"/>\n";
}

void SvgPlot::AddCentredText(std::string_view text) {
  content_ += "<text x=\"" + Px(left_ + 0.5 * PlotWidth()) + "\" y=\"" + Px(top_ + 0.5 * PlotHeight()) +
              "\" " + kFont + " font-size=\"14\" fill=\"#666666\" text-anchor=\"middle\">" +
              HtmlEscape(text) + "</text>\n";
}

std::string SvgPlot::RenderAxes() const {
  std::string out;
  const double x0 = left_, x1 = left_ + PlotWidth(), y0 = top_, y1 = top_ + PlotHeight();
  out += "<rect x=\"" + Px(x0) + "\" y=\"" + Px(y0) + "\" width=\"" + Px(PlotWidth()) + "\" height=\"" +
         Px(PlotHeight()) + "\" fill=\"#ffffff\" stroke=\"none\"/>\n";
  // x ticks and grid.
  if (!categories_.empty()) {
    for (size_t i = 0; i < categories_.size(); ++i) {
      const std::string px = Px(PixelX(static_cast<double>(i)));
      Append(&out, "<text x=\"", px, "\" y=\"", Px(y1 + 16), "\" ", kFont,
             " font-size=\"11\" text-anchor=\"middle\" fill=\"#333333\">", HtmlEscape(categories_[i]),
             "</text>\n");
    }
  } else {
    const Ticks ticks = NiceTicks(x_lo_, x_hi_, std::max(2, static_cast<int>(PlotWidth() / 90)));
    for (const double v : ticks.values) {
      const std::string px = Px(PixelX(v));
      Append(&out, "<line x1=\"", px, "\" y1=\"", Px(y0), "\" x2=\"", px, "\" y2=\"", Px(y1),
             "\" stroke=\"#e3e3e3\" stroke-width=\"1\"/>\n");
      Append(&out, "<text x=\"", px, "\" y=\"", Px(y1 + 16), "\" ", kFont,
             " font-size=\"11\" text-anchor=\"middle\" fill=\"#333333\">", FormatFixed(v, ticks.decimals),
             "</text>\n");
    }
  }
  // y ticks and grid.
  const Ticks ticks = NiceTicks(y_lo_, y_hi_, std::max(2, static_cast<int>(PlotHeight() / 50)));
  for (const double v : ticks.values) {
    const std::string py = Px(PixelY(v));
    Append(&out, "<line x1=\"", Px(x0), "\" y1=\"", py, "\" x2=\"", Px(x1), "\" y2=\"", py,
           "\" stroke=\"#e3e3e3\" stroke-width=\"1\"/>\n");
    Append(&out, "<text x=\"", Px(x0 - 6), "\" y=\"", Px(PixelY(v) + 4), "\" ", kFont,
           " font-size=\"11\" text-anchor=\"end\" fill=\"#333333\">", FormatFixed(v, ticks.decimals),
           "</text>\n");
  }
  if (!x_label_.empty()) {
    out += "<text x=\"" + Px(x0 + 0.5 * PlotWidth()) + "\" y=\"" + Px(height_ - 8) + "\" " + kFont +
           " font-size=\"12\" text-anchor=\"middle\" fill=\"#000000\">" + HtmlEscape(x_label_) + "</text>\n";
  }
  if (!y_label_.empty()) {
    const std::string cx = Px(14), cy = Px(y0 + 0.5 * PlotHeight());
    out += "<text x=\"" + cx + "\" y=\"" + cy + "\" transform=\"rotate(-90 " + cx + " " + cy + ")\" " +
           kFont + " font-size=\"12\" text-anchor=\"middle\" fill=\"#000000\">" + HtmlEscape(y_label_) +
           "</text>\n";
  }
  return out;
}

double SvgPlot::LegendWidth() const {
  size_t longest = 0;
  for (const LegendEntry& entry : legend_) longest = std::max(longest, entry.label.size());
  return 40.0 + 6.5 * static_cast<double>(longest);
}

std::string SvgPlot::RenderLegend() const {
  if (legend_.empty()) return {};
  const double box_width = LegendWidth();
  const double row = 17.0;
  const double box_height = 8.0 + row * static_cast<double>(legend_.size());
  // Candidate corners; the first with the fewest drawn points inside wins.
  const double right_x = left_ + PlotWidth() - box_width - 8, left_x = left_ + 8;
  const double top_y = top_ + 8, bottom_y = top_ + PlotHeight() - box_height - 8;
  const std::array<Eigen::Vector2d, 4> corners = {
      Eigen::Vector2d(right_x, top_y), Eigen::Vector2d(left_x, top_y), Eigen::Vector2d(right_x, bottom_y),
      Eigen::Vector2d(left_x, bottom_y)};
  size_t best = 0, best_count = std::numeric_limits<size_t>::max();
  for (size_t i = 0; i < corners.size(); ++i) {
    size_t count = 0;
    for (const Eigen::Vector2d& p : drawn_) {
      if (p.x() >= corners[i].x() - 4 && p.x() <= corners[i].x() + box_width + 4 &&
          p.y() >= corners[i].y() - 4 && p.y() <= corners[i].y() + box_height + 4) {
        ++count;
      }
    }
    if (count < best_count) {
      best = i;
      best_count = count;
    }
  }
  const double bx = legend_outside_ ? left_ + PlotWidth() + 8 : corners[best].x();
  const double by = legend_outside_ ? top_ : corners[best].y();
  std::string out = "<g class=\"legend\">\n<rect x=\"" + Px(bx) + "\" y=\"" + Px(by) + "\" width=\"" +
                    Px(box_width) + "\" height=\"" + Px(box_height) +
                    "\" fill=\"#ffffff\" fill-opacity=\"0.9\" stroke=\"#999999\" stroke-width=\"1\"/>\n";
  for (size_t i = 0; i < legend_.size(); ++i) {
    const LegendEntry& entry = legend_[i];
    const double cy = by + 4 + row * (static_cast<double>(i) + 0.5);
    const std::string colour = HtmlEscape(entry.colour);
    switch (entry.kind) {
      case LegendEntry::Kind::kLine:
      case LegendEntry::Kind::kDashedLine:
        out += "<line x1=\"" + Px(bx + 6) + "\" y1=\"" + Px(cy) + "\" x2=\"" + Px(bx + 30) + "\" y2=\"" +
               Px(cy) + "\" stroke=\"" + colour + "\" stroke-width=\"2.5\"" +
               DashAttribute(entry.kind == LegendEntry::Kind::kDashedLine) + "/>\n";
        break;
      case LegendEntry::Kind::kFilledMarker:
      case LegendEntry::Kind::kHollowMarker:
        out += "<circle cx=\"" + Px(bx + 18) + "\" cy=\"" + Px(cy) + "\" r=\"4.0\" fill=\"" +
               (entry.kind == LegendEntry::Kind::kFilledMarker ? colour : std::string("#ffffff")) +
               "\" stroke=\"" + colour + "\" stroke-width=\"1.5\"/>\n";
        break;
      case LegendEntry::Kind::kBox:
        out += "<rect x=\"" + Px(bx + 10) + "\" y=\"" + Px(cy - 5) +
               "\" width=\"16.0\" height=\"10.0\" fill=\"" + colour +
               "\" stroke=\"#333333\" stroke-width=\"1\"/>\n";
        break;
    }
    out += "<text x=\"" + Px(bx + 36) + "\" y=\"" + Px(cy + 4) + "\" " + kFont +
           " font-size=\"11\" fill=\"#000000\">" + HtmlEscape(entry.label) + "</text>\n";
  }
  out += "</g>\n";
  return out;
}

std::string SvgPlot::Render() const {
  const std::string clip_id = "clip-" + id_;
  std::string out = "<svg id=\"" + HtmlEscape(id_) +
                    "\" class=\"plot\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" + Px(width_) +
                    "\" height=\"" + Px(height_) + "\" viewBox=\"0 0 " + Px(width_) + " " + Px(height_) +
                    "\" role=\"img\">\n";
  out += "<defs><clipPath id=\"" + HtmlEscape(clip_id) + "\"><rect x=\"" + Px(left_) + "\" y=\"" + Px(top_) +
         "\" width=\"" + Px(PlotWidth()) + "\" height=\"" + Px(PlotHeight()) + "\"/></clipPath></defs>\n";
  out += RenderAxes();
  out += "<g class=\"data\" clip-path=\"url(#" + HtmlEscape(clip_id) + ")\">\n" + content_ + "</g>\n";
  out += "<rect x=\"" + Px(left_) + "\" y=\"" + Px(top_) + "\" width=\"" + Px(PlotWidth()) + "\" height=\"" +
         Px(PlotHeight()) + "\" fill=\"none\" stroke=\"#555555\" stroke-width=\"1\"/>\n";
  out += RenderLegend();
  out += "</svg>\n";
  return out;
}

}  // namespace mcvo::report_internal
