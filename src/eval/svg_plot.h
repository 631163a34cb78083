// Private to src/eval: the small SVG plotting kit behind report.html
// (report_html.cc). Everything it writes is deterministic: coordinates and
// tick labels go through FormatFixed (util/strings.h), text through
// HtmlEscape, and no floating-point value depends on iteration order.
//
// Conventions: a plot maps data (x right, y up) into an SVG viewport
// (x right, y DOWN) through a rectangular plot area inside margins. With an
// equal aspect the metres per pixel are the same along both axes (the
// ranges are widened about their centres to fill the area).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace mcvo::report_internal {

// Most points one polyline keeps (after decimation, see DecimatePolyline).
inline constexpr size_t kMaxPolylinePoints = 2000;

// HTML/XML text and attribute escaping: & < > " ' as entities; control
// characters other than tab and newline become U+FFFD (they are not allowed
// in HTML text). Bytes >= 0x80 pass through (UTF-8).
std::string HtmlEscape(std::string_view text);

// Nice tick step (1, 2 or 5 times a power of ten) for about `target` ticks
// over [lo, hi], and the ticks k * step inside it.
struct Ticks {
  double step = 1.0;
  int decimals = 0;  // digits after the point that show `step` exactly
  std::vector<double> values;
};
Ticks NiceTicks(double lo, double hi, int target);

// Reduces a polyline in PIXEL coordinates to at most max_points points:
// drops points closer than 0.1 px to the last kept one; beyond 8 max_points
// keeps two per bucket of consecutive points (the first and the farthest
// from the chord); then Ramer-Douglas-Peucker with a tolerance of 0.25 px,
// doubled until the result fits (spikes, being far from the chord,
// survive every step). The first and last points are always kept.
// Deterministic.
std::vector<Eigen::Vector2d> DecimatePolyline(const std::vector<Eigen::Vector2d>& pixels,
                                              size_t max_points = kMaxPolylinePoints);

struct LegendEntry {
  std::string label;
  std::string colour;
  enum class Kind { kLine, kDashedLine, kFilledMarker, kHollowMarker, kBox } kind = Kind::kLine;
};

class SvgPlot {
 public:
  // `id` becomes the svg element's id (a fixed ASCII name such as
  // "plot-trajectory"); width/height are the viewport in px.
  SvgPlot(std::string id, double width, double height);

  // Margins around the plot area (px).
  void SetMargins(double left, double right, double top, double bottom);
  // Data ranges. With equal_aspect, the ranges are widened so that one
  // data unit has the same length in px along x and y.
  void SetRanges(double x_lo, double x_hi, double y_lo, double y_hi, bool equal_aspect = false);
  void SetLabels(std::string x_label, std::string y_label);
  // Categorical x axis: labels at x = 0, 1, ..., n-1 instead of numeric ticks.
  void SetCategoricalX(std::vector<std::string> labels);

  double PixelX(double x) const;
  double PixelY(double y) const;
  Eigen::Vector2d Pixel(double x, double y) const { return {PixelX(x), PixelY(y)}; }
  double PlotWidth() const { return width_ - left_ - right_; }
  double PlotHeight() const { return height_ - top_ - bottom_; }

  // A polyline through data points; non-finite points break it into
  // separate runs. Decimated to kMaxPolylinePoints per run.
  void AddPolyline(const std::vector<Eigen::Vector2d>& points, std::string_view css_class,
                   std::string_view colour, double stroke_width, bool dashed = false);
  // Circle markers at data points.
  void AddMarkers(const std::vector<Eigen::Vector2d>& points, std::string_view css_class,
                  std::string_view colour, double radius, bool filled);
  // Square marker (start/end of a trajectory).
  void AddSquare(const Eigen::Vector2d& point, std::string_view css_class, std::string_view colour,
                 double half_size);
  // Vertical / horizontal line across the plot area at data x / y.
  void AddVerticalLine(double x, std::string_view css_class, std::string_view colour, bool dashed,
                       std::string_view label = {});
  void AddHorizontalLine(double y, std::string_view css_class, std::string_view colour, bool dashed,
                         std::string_view label = {});
  // Rectangle between data corners, with an optional tooltip (<title>).
  void AddRect(double x0, double y0, double x1, double y1, std::string_view css_class, std::string_view fill,
               std::string_view stroke, std::string_view tooltip = {});
  // Straight segment between data points.
  void AddSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, std::string_view css_class,
                  std::string_view colour, double stroke_width);
  // A message centred in the plot area (e.g. "no data").
  void AddCentredText(std::string_view text);
  // The legend goes into the corner of the plot area that covers the fewest
  // drawn points (ties: top right, top left, bottom right, bottom left), or
  // with `outside` into the right margin (make it LegendWidth() + 16 wide).
  void SetLegend(std::vector<LegendEntry> entries, bool outside = false) {
    legend_ = std::move(entries);
    legend_outside_ = outside;
  }
  double LegendWidth() const;

  // The <svg> element: frame, grid, ticks, labels, content, legend.
  std::string Render() const;

 private:
  std::string RenderAxes() const;
  std::string RenderLegend() const;
  // Records the pixels along a drawn segment (every 8 px) in drawn_.
  void NoteSegment(const Eigen::Vector2d& a_px, const Eigen::Vector2d& b_px);

  std::string id_;
  double width_, height_;
  double left_ = 70, right_ = 16, top_ = 14, bottom_ = 46;
  double x_lo_ = 0, x_hi_ = 1, y_lo_ = 0, y_hi_ = 1;
  std::string x_label_, y_label_;
  std::vector<std::string> categories_;
  std::vector<LegendEntry> legend_;
  bool legend_outside_ = false;
  std::string content_;
  // Pixel positions of everything drawn, for placing the legend where it
  // hides the least (the corner of the plot area with the fewest).
  std::vector<Eigen::Vector2d> drawn_;
};

// Fixed-point pixel coordinate text (one decimal).
std::string Px(double value);

}  // namespace mcvo::report_internal
