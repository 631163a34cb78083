// Classic detectors: Shi-Tomasi (min-eigenvalue response with 3x3 non-maximum
// suppression) and ORB/FAST. See classic_detectors.h for the choices.
#include "classic_detectors.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numeric>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/util/error.h"

namespace mcvo {
namespace internal {
namespace {

constexpr double kShiTomasiQuality = 0.01;      // of the strongest response in the image / in the cell
constexpr float kShiTomasiMinResponse = 1e-6f;  // absolute floor: a flat image has no corners
// A cell's threshold never drops below this multiple of the image's median
// response: flat regions (sky, a blank wall) have only sensor noise, whose
// cell maxima measured 0.1-4.8 x the median on rendered images with noise 0-2,
// against 6.8-190 x for weakly textured ground in the same images.
constexpr float kShiTomasiNoiseFactor = 5.0f;
constexpr int kOrbDescriptorBytes = 32;

void CheckInputs(const cv::Mat& image, const cv::Mat& mask) {
  MCVO_CHECK_MSG(image.type() == CV_8UC1, "detectors take CV_8UC1 images, got type ", image.type());
  MCVO_CHECK_MSG(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == image.size()),
                 "mask must be empty or CV_8UC1 of the image size");
}

// A detection at (x, y) is admissible when it lies at least border_px inside
// the image (pixel centres: [border, size - 1 - border]) and the mask is
// non-zero at its nearest pixel.
bool Admissible(float x, float y, const cv::Mat& image, const cv::Mat& mask, int border_px) {
  const float border = static_cast<float>(std::max(border_px, 0));
  if (!(x >= border && y >= border && x <= image.cols - 1 - border && y <= image.rows - 1 - border))
    return false;
  if (mask.empty()) return true;
  const int col = std::clamp(static_cast<int>(std::lround(x)), 0, mask.cols - 1);
  const int row = std::clamp(static_cast<int>(std::lround(y)), 0, mask.rows - 1);
  return mask.at<uint8_t>(row, col) != 0;
}

// The detections' order: decreasing score, then smaller y, then smaller x,
// then input order (a total order: std::sort gives what a stable sort
// would).
struct DetectionKey {
  float score, y, x;
  int index;
};

bool KeyBefore(const DetectionKey& a, const DetectionKey& b) {
  if (a.score != b.score) return a.score > b.score;
  if (a.y != b.y) return a.y < b.y;
  if (a.x != b.x) return a.x < b.x;
  return a.index < b.index;
}

std::vector<DetectionKey> MakeKeys(const std::vector<Eigen::Vector2f>& pixels, const std::vector<float>& scores) {
  std::vector<DetectionKey> keys(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) {
    keys[i] = DetectionKey{scores[i], pixels[i].y(), pixels[i].x(), static_cast<int>(i)};
  }
  return keys;
}

// The first max_candidates detections in KeyBefore's order.
std::vector<int> SortedOrder(const std::vector<Eigen::Vector2f>& pixels, const std::vector<float>& scores,
                             int max_candidates) {
  std::vector<DetectionKey> keys = MakeKeys(pixels, scores);
  const size_t keep = std::min(keys.size(), static_cast<size_t>(std::max(max_candidates, 0)));
  if (keep < keys.size()) {
    std::partial_sort(keys.begin(), keys.begin() + static_cast<std::ptrdiff_t>(keep), keys.end(), KeyBefore);
    keys.resize(keep);
  } else {
    std::sort(keys.begin(), keys.end(), KeyBefore);
  }
  std::vector<int> order(keys.size());
  for (size_t k = 0; k < keys.size(); ++k) order[k] = keys[k].index;
  return order;
}

// `order` (detections in SortedOrder's order) cut to max_candidates by
// (rank within the detection's cell, position in `order`): every cell's
// best first, then every cell's second, ... Returned in `order`'s order.
std::vector<int> BalancedPick(const std::vector<int>& order, const std::vector<Eigen::Vector2f>& pixels,
                              int max_candidates, int width, int height) {
  if (max_candidates <= 0) return {};
  if (static_cast<int>(order.size()) <= max_candidates) return order;
  const CandidateGrid grid(width, height);
  std::vector<int> seen(static_cast<size_t>(grid.NumCells()), 0);
  std::vector<int> rank(order.size(), 0);  // per position in order
  for (size_t k = 0; k < order.size(); ++k) {
    const Eigen::Vector2f& p = pixels[static_cast<size_t>(order[k])];
    rank[k] = seen[static_cast<size_t>(grid.Cell(grid.Col(p.x()), grid.Row(p.y())))]++;
  }
  // Counting sort of the positions by rank (stable: ties stay in order).
  const int ranks = *std::max_element(seen.begin(), seen.end());
  std::vector<int> start(static_cast<size_t>(ranks) + 1, 0);
  for (int r : rank) ++start[static_cast<size_t>(r) + 1];
  for (size_t r = 1; r < start.size(); ++r) start[r] += start[r - 1];
  std::vector<int> by_rank(order.size());
  for (size_t k = 0; k < order.size(); ++k) {
    by_rank[static_cast<size_t>(start[static_cast<size_t>(rank[k])]++)] = static_cast<int>(k);
  }
  by_rank.resize(static_cast<size_t>(max_candidates));
  std::sort(by_rank.begin(), by_rank.end());  // back to order's order
  std::vector<int> kept(by_rank.size());
  for (size_t k = 0; k < by_rank.size(); ++k) kept[k] = order[static_cast<size_t>(by_rank[k])];
  return kept;
}

}  // namespace

CandidateGrid::CandidateGrid(int width, int height) : width_(std::max(width, 1)), height_(std::max(height, 1)) {
  const double side = std::sqrt(static_cast<double>(width_) * height_ / kCandidateGridCells);
  side_ = std::clamp(static_cast<int>(std::lround(side)), kMinCandidateCellPx, kMaxCandidateCellPx);
  cols_ = (width_ + side_ - 1) / side_;
  rows_ = (height_ + side_ - 1) / side_;
}

int CandidateGrid::Col(float x) const {
  return std::clamp(static_cast<int>(std::floor(x)) / side_, 0, cols_ - 1);
}

int CandidateGrid::Row(float y) const {
  return std::clamp(static_cast<int>(std::floor(y)) / side_, 0, rows_ - 1);
}

cv::Rect CandidateGrid::Rect(int col, int row) const {
  const int x = col * side_, y = row * side_;
  return cv::Rect(x, y, std::min(side_, width_ - x), std::min(side_, height_ - y));
}

std::vector<int> SpatiallyBalancedOrder(const std::vector<Eigen::Vector2f>& pixels, const std::vector<float>& scores,
                                        int max_candidates, int width, int height) {
  MCVO_CHECK(pixels.size() == scores.size());
  return BalancedPick(SortedOrder(pixels, scores, static_cast<int>(pixels.size())), pixels, max_candidates, width,
                      height);
}

std::vector<int> CapWithSpreadExtras(const std::vector<Eigen::Vector2f>& pixels, const std::vector<float>& scores,
                                     int max_candidates, int width, int height) {
  MCVO_CHECK(pixels.size() == scores.size());
  if (max_candidates <= 0) return {};
  const size_t cap = static_cast<size_t>(max_candidates);
  if (pixels.size() <= cap) return SortedOrder(pixels, scores, static_cast<int>(pixels.size()));
  // What sorting every detection and BalancedPick over the ones after the
  // top would give, without sorting them all (a frame has thousands of
  // detections and keeps a few hundred): the top by nth_element, and of
  // the rest only each cell's best few, as deep as the per-cell ranks the
  // pick can reach.
  std::vector<DetectionKey> keys = MakeKeys(pixels, scores);
  std::nth_element(keys.begin(), keys.begin() + static_cast<std::ptrdiff_t>(cap), keys.end(), KeyBefore);
  std::sort(keys.begin(), keys.begin() + static_cast<std::ptrdiff_t>(cap), KeyBefore);
  std::vector<int> order(cap);
  for (size_t k = 0; k < cap; ++k) order[k] = keys[k].index;
  const size_t rest = keys.size() - cap;
  if (rest <= cap) {
    std::sort(keys.begin() + static_cast<std::ptrdiff_t>(cap), keys.end(), KeyBefore);
    for (size_t k = cap; k < keys.size(); ++k) order.push_back(keys[k].index);
    return order;
  }
  // The rest by cell.
  const CandidateGrid grid(width, height);
  std::vector<std::vector<DetectionKey>> cells(static_cast<size_t>(grid.NumCells()));
  for (size_t k = cap; k < keys.size(); ++k) {
    const Eigen::Vector2f& p = pixels[static_cast<size_t>(keys[k].index)];
    cells[static_cast<size_t>(grid.Cell(grid.Col(p.x()), grid.Row(p.y())))].push_back(keys[k]);
  }
  // BalancedPick keeps the cap first by (rank in cell, order): every rank
  // under `depth` - 1, where depth is the least with sum min(count, depth)
  // >= cap, and of rank depth - 1 the best by order.
  size_t depth = 0, below = 0;  // below: sum of min(count, depth)
  while (below < cap) {
    ++depth;
    below = 0;
    for (const auto& cell : cells) below += std::min(cell.size(), depth);
  }
  std::vector<DetectionKey> picked, last_rank;
  for (auto& cell : cells) {
    const size_t keep = std::min(cell.size(), depth);
    std::partial_sort(cell.begin(), cell.begin() + static_cast<std::ptrdiff_t>(keep), cell.end(), KeyBefore);
    for (size_t r = 0; r < keep; ++r) (r + 1 < depth ? picked : last_rank).push_back(cell[r]);
  }
  const size_t from_last = cap - picked.size();
  std::partial_sort(last_rank.begin(), last_rank.begin() + static_cast<std::ptrdiff_t>(from_last), last_rank.end(),
                    KeyBefore);
  picked.insert(picked.end(), last_rank.begin(), last_rank.begin() + static_cast<std::ptrdiff_t>(from_last));
  std::sort(picked.begin(), picked.end(), KeyBefore);
  for (const DetectionKey& key : picked) order.push_back(key.index);
  return order;
}

namespace {

// A float's bits as an unsigned key in the float's order (-0 before +0;
// not for NaN), and back.
uint32_t OrderKey(float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  return (bits & 0x80000000u) != 0 ? ~bits : bits | 0x80000000u;
}

float FromOrderKey(uint32_t key) {
  const uint32_t bits = (key & 0x80000000u) != 0 ? key & 0x7fffffffu : ~key;
  float value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

}  // namespace

// The value at position `rank` of `values` sorted (what std::nth_element
// puts there), by two passes of a 16-bit radix select: O(n), no reordering.
// histogram: scratch of 65536 counts.
float RankedValue(const std::vector<float>& values, size_t rank, std::vector<uint32_t>* histogram) {
  MCVO_CHECK(rank < values.size());
  histogram->assign(size_t{1} << 16, 0);
  for (const float v : values) ++(*histogram)[OrderKey(v) >> 16];
  uint32_t high = 0;
  size_t below = 0;
  while (below + (*histogram)[high] <= rank) below += (*histogram)[high++];
  histogram->assign(size_t{1} << 16, 0);
  for (const float v : values) {
    const uint32_t key = OrderKey(v);
    if ((key >> 16) == high) ++(*histogram)[key & 0xffffu];
  }
  uint32_t low = 0;
  while (below + (*histogram)[low] <= rank) below += (*histogram)[low++];
  return FromOrderKey(high << 16 | low);
}

namespace {

// Offset in [-0.5, 0.5] of the vertex of the parabola through (-1, left),
// (0, centre), (1, right); 0 when the samples do not bend down.
float ParabolaPeak(float left, float centre, float right) {
  const float curvature = left + right - 2.0f * centre;
  if (!(curvature < 0.0f)) return 0.0f;
  return std::clamp(0.5f * (left - right) / curvature, -0.5f, 0.5f);
}

class ShiTomasiDetector : public Detector {
 public:
  std::string Name() const override { return "shi_tomasi"; }
  int DescriptorSize() const override { return 0; }
  int DescriptorType() const override { return CV_32F; }

  Detections Detect(const cv::Mat& image, const cv::Mat& mask, int max_candidates, int border_px) override {
    CheckInputs(image, mask);
    Detections out;
    if (max_candidates <= 0 || image.rows < 3 || image.cols < 3) return out;
    cv::cornerMinEigenVal(image, response_, /*blockSize=*/3, /*ksize=*/3, cv::BORDER_REFLECT_101);
    const CandidateGrid grid(image.cols, image.rows);
    const std::vector<float> thresholds = CellThresholds(grid);

    // The cell of each column, once (no division per pixel), and the lowest
    // threshold, under which no pixel of any cell passes.
    column_cells_.resize(static_cast<size_t>(response_.cols));
    for (int x = 0; x < response_.cols; ++x) column_cells_[static_cast<size_t>(x)] = grid.Col(static_cast<float>(x));
    const float lowest = *std::min_element(thresholds.begin(), thresholds.end());
    // Pixels that are a (non-strict) 3x3 maximum and pass the lowest
    // threshold, found by OpenCV's vectorised dilate and comparisons, so the
    // scalar test below runs on those only: c >= every neighbour is the
    // "after it not larger" half of the rule; the strict half is checked
    // there. The same detections in the same raster order as testing every
    // pixel.
    cv::dilate(response_, dilated_, cv::Mat());
    cv::compare(response_, dilated_, is_max_, cv::CMP_GE);
    cv::compare(response_, lowest, above_lowest_, cv::CMP_GE);
    cv::bitwise_and(is_max_, above_lowest_, is_max_);
    std::vector<Eigen::Vector2f> pixels;
    std::vector<float> scores;
    for (int y = 1; y + 1 < response_.rows; ++y) {
      const float* above = response_.ptr<float>(y - 1);
      const float* row = response_.ptr<float>(y);
      const uint8_t* flags = is_max_.ptr<uint8_t>(y);
      const float* row_thresholds = &thresholds[static_cast<size_t>(grid.Cell(0, grid.Row(static_cast<float>(y))))];
      const int end = response_.cols - 1;
      for (int x = 1; x < end; ++x) {
        // Eight flags at a time: most of a row is no candidate.
        if (x + 8 <= end) {
          uint64_t word;
          std::memcpy(&word, flags + x, sizeof word);
          if (word == 0) {
            x += 7;
            continue;
          }
        }
        if (flags[x] == 0) continue;
        const float c = row[x];
        if (c < row_thresholds[column_cells_[static_cast<size_t>(x)]]) continue;
        // Strict 3x3 maximum; on a plateau the first pixel in raster order wins
        // (neighbours before it must be smaller, after it not larger).
        if (!(above[x - 1] < c && above[x] < c && above[x + 1] < c && row[x - 1] < c)) continue;
        const float* below = response_.ptr<float>(y + 1);
        const float px = static_cast<float>(x) + ParabolaPeak(row[x - 1], c, row[x + 1]);
        const float py = static_cast<float>(y) + ParabolaPeak(above[x], c, below[x]);
        if (!Admissible(px, py, image, mask, border_px)) continue;
        pixels.emplace_back(px, py);
        scores.push_back(c);
      }
    }
    for (int i : CapWithSpreadExtras(pixels, scores, max_candidates, image.cols, image.rows)) {
      out.pixels.push_back(pixels[i]);
      out.scores.push_back(scores[i]);
    }
    return out;
  }

 private:
  // Per cell: kShiTomasiQuality of the cell's strongest response, but at
  // least kShiTomasiNoiseFactor x the median response of the image and at
  // most kShiTomasiQuality of the image's strongest (the global rule), so a
  // weakly textured region next to strong edges still gets candidates.
  std::vector<float> CellThresholds(const CandidateGrid& grid) {
    // The image's maximum is the largest cell maximum (the cells tile it).
    std::vector<double> cell_max(static_cast<size_t>(grid.NumCells()), 0.0);
    double max_response = 0.0;
    for (int r = 0; r < grid.rows(); ++r) {
      for (int c = 0; c < grid.cols(); ++c) {
        double value = 0.0;
        cv::minMaxLoc(response_(grid.Rect(c, r)), nullptr, &value);
        cell_max[static_cast<size_t>(grid.Cell(c, r))] = value;
        max_response = c == 0 && r == 0 ? value : std::max(max_response, value);
      }
    }
    const float global = std::max(static_cast<float>(kShiTomasiQuality * max_response), kShiTomasiMinResponse);
    // Median over every second pixel of every second row (deterministic, cheap).
    samples_.clear();
    for (int y = 0; y < response_.rows; y += 2) {
      const float* row = response_.ptr<float>(y);
      for (int x = 0; x < response_.cols; x += 2) samples_.push_back(row[x]);
    }
    const float noise_floor = std::max(kShiTomasiNoiseFactor * RankedValue(samples_, samples_.size() / 2, &histogram_),
                                       kShiTomasiMinResponse);
    std::vector<float> thresholds(static_cast<size_t>(grid.NumCells()), global);
    for (size_t cell = 0; cell < thresholds.size(); ++cell) {
      const float local = std::max(static_cast<float>(kShiTomasiQuality * cell_max[cell]), noise_floor);
      thresholds[cell] = std::min(global, local);
    }
    return thresholds;
  }

  cv::Mat response_;             // reused between frames
  cv::Mat dilated_, is_max_, above_lowest_;  // reused between frames
  std::vector<float> samples_;  // reused between frames
  std::vector<int> column_cells_;  // reused between frames
  std::vector<uint32_t> histogram_;  // reused between frames
};

class OrbDetector : public Detector {
 public:
  OrbDetector()
      : orb_(cv::ORB::create(/*nfeatures=*/500, /*scaleFactor=*/1.2f, /*nlevels=*/8, /*edgeThreshold=*/31,
                             /*firstLevel=*/0, /*WTA_K=*/2, cv::ORB::FAST_SCORE, /*patchSize=*/31,
                             /*fastThreshold=*/20)) {}

  std::string Name() const override { return "orb"; }
  int DescriptorSize() const override { return kOrbDescriptorBytes; }
  int DescriptorType() const override { return CV_8U; }

  Detections Detect(const cv::Mat& image, const cv::Mat& mask, int max_candidates, int border_px) override {
    CheckInputs(image, mask);
    Detections out;
    out.descriptors = cv::Mat(0, kOrbDescriptorBytes, CV_8U);
    if (max_candidates <= 0) return out;
    // The border goes into the detection mask too, so that ORB's per-level
    // budget is not spent on points dropped afterwards.
    cv::Mat detect_mask = cv::Mat::zeros(image.size(), CV_8UC1);
    const int border = std::max(border_px, 0);
    if (image.cols > 2 * border && image.rows > 2 * border) {
      const cv::Rect inner(border, border, image.cols - 2 * border, image.rows - 2 * border);
      if (mask.empty()) {
        detect_mask(inner).setTo(255);
      } else {
        mask(inner).copyTo(detect_mask(inner));
      }
    }
    orb_->setMaxFeatures(max_candidates);
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    orb_->detectAndCompute(image, detect_mask, keypoints, descriptors);
    MCVO_CHECK(descriptors.empty() || descriptors.rows == static_cast<int>(keypoints.size()));

    // Keypoints of coarse levels are scaled to level 0 and may land just
    // outside the mask: check again at full resolution.
    std::vector<Eigen::Vector2f> pixels;
    std::vector<float> scores;
    std::vector<int> rows;
    for (size_t i = 0; i < keypoints.size(); ++i) {
      const cv::Point2f& pt = keypoints[i].pt;
      if (!Admissible(pt.x, pt.y, image, mask, border_px)) continue;
      pixels.emplace_back(pt.x, pt.y);
      scores.push_back(keypoints[i].response);
      rows.push_back(static_cast<int>(i));
    }
    const std::vector<int> order = SortedOrder(pixels, scores, max_candidates);
    out.descriptors = cv::Mat(static_cast<int>(order.size()), kOrbDescriptorBytes, CV_8U);
    for (size_t k = 0; k < order.size(); ++k) {
      const int i = order[k];
      out.pixels.push_back(pixels[i]);
      out.scores.push_back(scores[i]);
      descriptors.row(rows[i]).copyTo(out.descriptors.row(static_cast<int>(k)));
    }
    return out;
  }

 private:
  cv::Ptr<cv::ORB> orb_;
};

}  // namespace

std::unique_ptr<Detector> MakeShiTomasiDetector() { return std::make_unique<ShiTomasiDetector>(); }
std::unique_ptr<Detector> MakeOrbDetector() { return std::make_unique<OrbDetector>(); }

}  // namespace internal
}  // namespace mcvo
