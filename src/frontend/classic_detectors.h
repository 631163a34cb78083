// Private to the frontend module: the classic detectors behind Detector
// (include/mcvo/frontend/detector.h), built by CreateDetector.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/types.hpp>

#include "mcvo/frontend/detector.h"

namespace mcvo {
namespace internal {

// About kCandidateGridCells square cells over the image, side clamped to
// [kMinCandidateCellPx, kMaxCandidateCellPx] (704 x 188: 47 px, 15 x 4 cells;
// 1408 x 376: 91 px; 1400 x 1400: 128 px). The last column / row may be
// narrower.
constexpr int kCandidateGridCells = 64;
constexpr int kMinCandidateCellPx = 24;
constexpr int kMaxCandidateCellPx = 128;

class CandidateGrid {
 public:
  CandidateGrid(int width, int height);
  int cols() const { return cols_; }
  int rows() const { return rows_; }
  int side() const { return side_; }
  int NumCells() const { return cols_ * rows_; }
  int Col(float x) const;  // clamped into the grid
  int Row(float y) const;
  int Cell(int col, int row) const { return row * cols_ + col; }
  cv::Rect Rect(int col, int row) const;

 private:
  int width_, height_, side_ = 1, cols_ = 1, rows_ = 1;
};

// Indices of the detections to keep when at most max_candidates may go on,
// sorted by decreasing score (ties: smaller y, then smaller x, then index).
// All of them when they fit. Otherwise they are kept by their rank within
// their CandidateGrid cell, every cell's best first, then every cell's
// second best, ... (ties of rank by score): a cap never hands every slot to
// the strong corners of one region while weaker texture elsewhere, which the
// selection would spread features over, gets nothing.
std::vector<int> SpatiallyBalancedOrder(const std::vector<Eigen::Vector2f>& pixels, const std::vector<float>& scores,
                                        int max_candidates, int width, int height);

// The value at position `rank` of `values` sorted by <, what
// std::nth_element puts there (-0 and +0 both compare equal to 0), without
// reordering `values`: a 16-bit radix select on the floats' bits, two
// passes. Not for NaN. histogram: scratch, resized here.
float RankedValue(const std::vector<float>& values, size_t rank, std::vector<uint32_t>* histogram);

// The cap of the Shi-Tomasi and network detectors (Detector::Detect): the
// best max_candidates by score, as before, plus up to max_candidates more
// of the others chosen by SpatiallyBalancedOrder; all of them in score
// order (ties: smaller y, then smaller x, then index), so the first
// max_candidates are the top by score. The camera tracker selects from the
// top first and reaches into the extras only for the features the top
// cannot place (strong corners bunched on a few edges, weak texture
// elsewhere: an open landscape whose ground is grass).
std::vector<int> CapWithSpreadExtras(const std::vector<Eigen::Vector2f>& pixels, const std::vector<float>& scores,
                                     int max_candidates, int width, int height);

// Shi-Tomasi: the minimum eigenvalue of the 3x3 structure tensor
// (cv::cornerMinEigenVal, Sobel aperture 3) is the score; candidates are its
// strict 3x3 local maxima above a threshold per CandidateGrid cell: 1% of the
// cell's maximum response (the quality level of cv::goodFeaturesToTrack in
// VINS, applied per cell), at least 5x the image's median response (sensor
// noise in flat regions) and at most 1% of the image's maximum (the global
// rule). Refined to sub-pixel by a separable parabola fit through the peak and
// its neighbours. A cap keeps candidates by CapWithSpreadExtras. No minimum
// distance here: spacing is the selection's job (frontend/selection.h), which
// needs every candidate with its score. No descriptors.
std::unique_ptr<Detector> MakeShiTomasiDetector();

// ORB: cv::ORB with the FAST score (keypoint.response is the score), 8 levels
// at scale 1.2, edge threshold and patch 31 px (OpenCV defaults; descriptors
// need that margin), 32-byte rBRIEF descriptors (CV_8U rows) of the returned
// candidates.
std::unique_ptr<Detector> MakeOrbDetector();

}  // namespace internal
}  // namespace mcvo
