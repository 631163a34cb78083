// Feature selection (3-priority quad-tree, plain quad-tree, score) and the
// SFD metric. Everything is single-threaded and ordered: stable sorts, ties
// broken by index, so the output is a function of the input alone.
//
// The 3-priority quad-tree as implemented here (reference notes, "3-priority
// quad-tree selection"; paper, Sec. "3-priority quad-tree"):
//  1. Points of the tree: the tracked features and the admissible candidates
//     (inside the image, mask non-zero at the nearest pixel). Roots: a row
//     (or column) of round(w / h) near-square nodes covering the image.
//  2. Quantity priority: while fewer than `wanted` = max_features - tracked
//     leaves are *free* (hold a candidate and no tracked feature), split the
//     splittable leaf holding the most points (ties: the oldest leaf) into
//     four; empty children are dropped. A leaf is splittable when it holds
//     more than one point, at least one candidate, and both sides are over
//     1 px. (So the leaf count reaches wanted + leaves holding tracked
//     features, counting only leaves where a new feature can go.)
//  3. Tracked priority: a leaf that holds a tracked feature contributes
//     nothing. Score priority: every free leaf contributes its best candidate.
//  4. The leaf winners, by decreasing score, are accepted greedily when no
//     tracked or already accepted feature is closer than min_distance_px;
//     stop at `wanted`. If the minimum distance rejected winners and fewer
//     than `wanted` were accepted, the other candidates of free leaves fill
//     up, by score, under the same rule.
// kQuadtree is the same without step 3's tracked rule: the tree holds the
// candidates only, splits until `wanted` leaves, and every leaf contributes
// its best candidate (tracked features act only through the distance rule).
#include "mcvo/frontend/selection.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>

#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr float kMinNodeSidePx = 1.0f;

bool InsideAndUnmasked(const Eigen::Vector2f& p, const SelectionInput& input) {
  if (!std::isfinite(p.x()) || !std::isfinite(p.y())) return false;
  if (input.image_width > 0 && (p.x() < -0.5f || p.x() >= input.image_width - 0.5f)) return false;
  if (input.image_height > 0 && (p.y() < -0.5f || p.y() >= input.image_height - 0.5f)) return false;
  if (input.mask.empty()) return true;
  const int col = std::clamp(static_cast<int>(std::lround(p.x())), 0, input.mask.cols - 1);
  const int row = std::clamp(static_cast<int>(std::lround(p.y())), 0, input.mask.rows - 1);
  return input.mask.at<uint8_t>(row, col) != 0;
}

// Candidate indices sorted by decreasing score, ties by index.
void SortByScore(const std::vector<float>& scores, std::vector<int>* indices) {
  std::stable_sort(indices->begin(), indices->end(), [&](int a, int b) {
    if (scores[a] != scores[b]) return scores[a] > scores[b];
    return a < b;
  });
}

// Greedy acceptance under the minimum distance (to tracked features and to
// the features already accepted), up to `wanted` in `chosen`.
class DistanceGate {
 public:
  DistanceGate(const SelectionInput& input, int wanted)
      : pixels_(input.candidates->pixels),
        min_distance_sq_(static_cast<float>(input.min_distance_px * input.min_distance_px)),
        wanted_(wanted),
        occupied_(input.tracked) {}

  bool Full() const { return static_cast<int>(chosen_.size()) >= wanted_; }

  void Offer(int index) {
    if (Full() || taken_.count(index)) return;
    const Eigen::Vector2f& p = pixels_[index];
    for (const Eigen::Vector2f& q : occupied_) {
      if ((p - q).squaredNorm() < min_distance_sq_) return;
    }
    occupied_.push_back(p);
    chosen_.push_back(index);
    taken_.insert(index);
  }

  std::vector<int> Take() { return std::move(chosen_); }

 private:
  const std::vector<Eigen::Vector2f>& pixels_;
  float min_distance_sq_;
  int wanted_;
  std::vector<Eigen::Vector2f> occupied_;
  std::vector<int> chosen_;
  std::set<int> taken_;
};

struct Node {
  float x0, y0, x1, y1;
  std::vector<int> points;  // indices into the tree's point list
  int num_tracked = 0;
  int num_candidates = 0;
};

// The quad tree of steps 1-2 over `points` (the first num_tracked of them
// tracked). Returns the leaves, in creation order.
std::vector<Node> BuildQuadTree(const std::vector<Eigen::Vector2f>& points, int num_tracked, int width,
                                int height, int wanted) {
  const auto is_tracked = [&](int i) { return i < num_tracked; };
  const auto is_free = [](const Node& n) { return n.num_tracked == 0 && n.num_candidates > 0; };
  const auto fill = [&](Node* node, int i) {
    node->points.push_back(i);
    ++(is_tracked(i) ? node->num_tracked : node->num_candidates);
  };

  // Roots: near-square nodes along the longer side.
  const float w = static_cast<float>(std::max(width, 1));
  const float h = static_cast<float>(std::max(height, 1));
  const bool wide = w >= h;
  const int num_roots = std::max(1, static_cast<int>(std::lround(wide ? w / h : h / w)));
  std::vector<Node> leaves;
  for (int r = 0; r < num_roots; ++r) {
    Node node;
    node.x0 = wide ? -0.5f + w * r / num_roots : -0.5f;
    node.x1 = wide ? -0.5f + w * (r + 1) / num_roots : w - 0.5f;
    node.y0 = wide ? -0.5f : -0.5f + h * r / num_roots;
    node.y1 = wide ? h - 0.5f : -0.5f + h * (r + 1) / num_roots;
    leaves.push_back(node);
  }
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    const float t = wide ? (points[i].x() + 0.5f) / w : (points[i].y() + 0.5f) / h;
    fill(&leaves[std::clamp(static_cast<int>(std::floor(t * num_roots)), 0, num_roots - 1)], i);
  }
  leaves.erase(std::remove_if(leaves.begin(), leaves.end(), [](const Node& n) { return n.points.empty(); }),
               leaves.end());

  int num_free = static_cast<int>(std::count_if(leaves.begin(), leaves.end(), is_free));
  std::vector<bool> alive(leaves.size(), true);
  while (num_free < wanted) {
    // Quantity priority: the splittable leaf with the most points, oldest first.
    int best = -1;
    for (int i = 0; i < static_cast<int>(leaves.size()); ++i) {
      const Node& n = leaves[i];
      if (!alive[i] || n.points.size() < 2 || n.num_candidates == 0) continue;
      if (n.x1 - n.x0 <= kMinNodeSidePx || n.y1 - n.y0 <= kMinNodeSidePx) continue;
      if (best < 0 || n.points.size() > leaves[best].points.size()) best = i;
    }
    if (best < 0) break;
    Node parent = std::move(leaves[best]);
    alive[best] = false;
    num_free -= is_free(parent) ? 1 : 0;
    const float mx = 0.5f * (parent.x0 + parent.x1);
    const float my = 0.5f * (parent.y0 + parent.y1);
    Node children[4];
    for (int c = 0; c < 4; ++c) {
      children[c].x0 = (c & 1) ? mx : parent.x0;
      children[c].x1 = (c & 1) ? parent.x1 : mx;
      children[c].y0 = (c & 2) ? my : parent.y0;
      children[c].y1 = (c & 2) ? parent.y1 : my;
    }
    for (int i : parent.points) {
      fill(&children[(points[i].x() >= mx ? 1 : 0) + (points[i].y() >= my ? 2 : 0)], i);
    }
    for (Node& child : children) {
      if (child.points.empty()) continue;
      num_free += is_free(child) ? 1 : 0;
      leaves.push_back(std::move(child));
      alive.push_back(true);
    }
  }
  std::vector<Node> result;
  for (size_t i = 0; i < leaves.size(); ++i) {
    if (alive[i]) result.push_back(std::move(leaves[i]));
  }
  return result;
}

std::vector<int> SelectByTree(const SelectionInput& input, const std::vector<int>& admissible, int wanted,
                              bool tracked_priority) {
  MCVO_CHECK_MSG(input.image_width > 0 && input.image_height > 0, "the quad tree needs the image size");
  const Detections& candidates = *input.candidates;
  std::vector<Eigen::Vector2f> points;
  const int num_tracked = tracked_priority ? static_cast<int>(input.tracked.size()) : 0;
  if (tracked_priority) points = input.tracked;
  for (int c : admissible) points.push_back(candidates.pixels[c]);
  const std::vector<Node> leaves =
      BuildQuadTree(points, num_tracked, input.image_width, input.image_height, wanted);

  std::vector<int> winners;
  std::vector<int> others;
  for (const Node& leaf : leaves) {
    if (leaf.num_tracked > 0 || leaf.num_candidates == 0) continue;
    std::vector<int> in_leaf;
    for (int i : leaf.points) in_leaf.push_back(admissible[i - num_tracked]);
    SortByScore(candidates.scores, &in_leaf);
    winners.push_back(in_leaf.front());
    others.insert(others.end(), in_leaf.begin() + 1, in_leaf.end());
  }
  SortByScore(candidates.scores, &winners);
  SortByScore(candidates.scores, &others);
  DistanceGate gate(input, wanted);
  for (int c : winners) gate.Offer(c);
  for (int c : others) gate.Offer(c);
  return gate.Take();
}

}  // namespace

std::vector<int> SelectFeatures(const SelectionInput& input, FeatureSelection method) {
  MCVO_CHECK(input.candidates != nullptr);
  const Detections& candidates = *input.candidates;
  MCVO_CHECK(candidates.scores.size() == candidates.pixels.size());
  MCVO_CHECK(input.mask.empty() || input.mask.type() == CV_8UC1);
  const int wanted = std::max(0, input.max_features - static_cast<int>(input.tracked.size()));
  if (wanted == 0) return {};

  std::vector<int> admissible;
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) {
    if (InsideAndUnmasked(candidates.pixels[i], input)) admissible.push_back(i);
  }
  switch (method) {
    case FeatureSelection::kThreePriority:
      return SelectByTree(input, admissible, wanted, /*tracked_priority=*/true);
    case FeatureSelection::kQuadtree:
      return SelectByTree(input, admissible, wanted, /*tracked_priority=*/false);
    case FeatureSelection::kScore: {
      SortByScore(candidates.scores, &admissible);
      DistanceGate gate(input, wanted);
      for (int c : admissible) gate.Offer(c);
      return gate.Take();
    }
  }
  MCVO_CHECK_MSG(false, "unknown selection method ", static_cast<int>(method));
  return {};
}

// Population variance (divide by the number of cells) of the per-cell counts.
// Cell of a pixel: floor((x + 0.5) * cols / width) (pixel centres at integer
// coordinates, so the image spans [-0.5, width - 0.5)); pixels outside the
// image are not counted.
double ComputeSfd(const std::vector<Eigen::Vector2f>& pixels, int image_width, int image_height,
                  int grid_cols, int grid_rows) {
  MCVO_CHECK(image_width > 0 && image_height > 0 && grid_cols > 0 && grid_rows > 0);
  std::vector<int> counts(static_cast<size_t>(grid_cols) * grid_rows, 0);
  for (const Eigen::Vector2f& p : pixels) {
    const double u = (static_cast<double>(p.x()) + 0.5) * grid_cols / image_width;
    const double v = (static_cast<double>(p.y()) + 0.5) * grid_rows / image_height;
    if (!(u >= 0.0 && u < grid_cols && v >= 0.0 && v < grid_rows)) continue;
    ++counts[static_cast<size_t>(std::floor(v)) * grid_cols + static_cast<size_t>(std::floor(u))];
  }
  const double n = static_cast<double>(counts.size());
  const double mean = std::accumulate(counts.begin(), counts.end(), 0.0) / n;
  double sum_sq = 0.0;
  for (int c : counts) sum_sq += (c - mean) * (c - mean);
  return sum_sq / n;
}

}  // namespace mcvo
