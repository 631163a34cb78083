// Brute-force k-nearest-neighbour matching of binary descriptors (ORB's
// 32-byte rows) by Hamming distance, for loop verification and
// relocalisation (loop_closer.h).
//
// The result is what OpenCV's brute-force matcher returns (cv::BFMatcher,
// NORM_HAMMING, knnMatch; tested against it): for every query row, in
// query order, the min(k, train rows) nearest train rows, nearest first, a
// tie keeping the lower train row first. It is written here because
// OpenCV's matcher spends most of its time in per-pair call overhead
// (instrumentation and dispatch around each distance); packed into four
// 64-bit words, a distance is four popcounts. Measured on the 1.18 km
// route and the loop benchmark's block route: README.md, "Loop closure over
// the synthetic suite".
//
// Deterministic: the query rows are split into contiguous blocks over
// `threads` (0: all cores); each row is matched on its own, so the result
// does not depend on the thread count.
#pragma once

#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

namespace mcvo {

// query, train: CV_8UC1 with 32 columns (or empty). Throws InternalError
// otherwise.
std::vector<std::vector<cv::DMatch>> HammingKnnMatch(const cv::Mat& query, const cv::Mat& train, int k,
                                                     int threads);

}  // namespace mcvo
