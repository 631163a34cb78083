// Affine alignment of a feature's first patch to a later image: the anchor
// check of the LK tracker (FrontendOptions::anchor, docs/config.md).
//
// Frame-to-frame LK moves each feature by the flow between two consecutive
// images; its small errors add up along a track (a random walk of about
// 0.2 px per frame on the rendered KITTI-360 rig, 1-2 px after 10-30
// frames, results/anchor_tracking.md). For a rig without overlapping views
// those correlated errors bias the metric scale (the 3-camera rig's scale
// came out 3-6 % short; with the renderer's true pixels on the same tracks,
// 0.05 %). The anchor holds the patch around the feature where it was
// detected; every later position is refined by aligning that patch to the
// new image under an affine warp and a gain and offset of the intensities
// (zero-mean, unit-norm patches), starting from the LK position and the
// warp of the previous frame. The error no longer accumulates, and a
// feature whose patch no longer matches (an occlusion boundary sliding
// through it, a T-junction, a change no affine warp explains) is dropped.
//
// Inverse compositional Gauss-Newton (Baker and Matthews, "Lucas-Kanade 20
// Years On", 2004): the template's steepest-descent images and Hessian are
// computed once per anchor, so an iteration costs one bilinear sample and
// six multiply-adds per template pixel. OpenCV has no per-feature affine
// tracker (cv::findTransformECC aligns whole images and recomputes their
// gradients on every call), hence written here.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace mcvo {

struct PatchAlignOptions {
  int half_size_px = 10;  // template of (2 h + 1)^2 pixels
  // Gaussian weight of the template pixels around the feature (standard
  // deviation, pixels); 0: uniform. A patch on a depth edge (a corner
  // against the background) mixes two motions, and the affine warp cannot
  // follow the perspective change of a slanted surface under forward
  // motion: the fitted position runs ahead of the truth by a term that
  // grows with the weighted area (docs/config.md, anchor.weight_sigma_px).
  double weight_sigma_px = 3.0;
  int max_iterations = 15;
  double convergence_px = 0.01;  // stop when no template corner moves more
  // Smallest normalised cross-correlation of the aligned patch with the
  // template; below it the feature is lost.
  double min_zncc = 0.8;
  // Largest distance between the aligned position and the LK position.
  double max_shift_px = 3.0;
  // Largest change of the warp in one alignment: the singular values of
  // new warp x old warp^-1 stay in [1 / c, c]. Between consecutive frames a
  // patch zooms or shears little; a free affine warp that changes more has
  // fitted other texture.
  double max_warp_change = 1.6;
};

// True when `warp` has a singular value outside [1 / scale, scale]: the
// patch has zoomed or sheared so far since its template was taken that the
// tracker takes a new one (re-anchors) at the aligned position.
bool WarpBeyond(const Eigen::Matrix2f& warp, double scale);

// The template of one feature. Valid when its Hessian is well conditioned
// (a textured patch inside the image).
struct PatchAnchor {
  bool valid = false;
  Eigen::VectorXf values;   // zero-mean, unit-norm template, row-major
  Eigen::VectorXf weights;  // per template pixel (PatchAlignOptions::weight_sigma_px)
  // Steepest-descent images of the normalised template (one row per pixel,
  // 6 columns), weighted, and the inverse of the weighted Hessian.
  Eigen::Matrix<float, Eigen::Dynamic, 6> steepest;
  Eigen::Matrix<float, 6, 6> hessian_inverse;
  // Warp from template coordinates (centred on the feature) to the image of
  // the last successful alignment: y = warp * x + position.
  Eigen::Matrix2f warp = Eigen::Matrix2f::Identity();
};

// Template around `pixel` of `image` (CV_8UC1). Invalid (valid == false)
// when the patch leaves the image or has too little texture.
PatchAnchor MakePatchAnchor(const cv::Mat& image, const Eigen::Vector2f& pixel, const PatchAlignOptions& options);

enum class PatchAlignStatus { kAligned, kOutsideImage, kNoMatch };

struct PatchAlignResult {
  PatchAlignStatus status = PatchAlignStatus::kNoMatch;
  Eigen::Vector2f pixel = Eigen::Vector2f::Zero();  // aligned position (kAligned)
  Eigen::Matrix2f warp = Eigen::Matrix2f::Identity();
  double zncc = 0.0;
  int iterations = 0;
  double last_step_px = 0.0;  // largest move of a template corner in the last iteration
};

// Aligns `anchor` to `image` (CV_8UC1) from `initial_pixel` and the
// anchor's last warp. kOutsideImage: the warped template leaves the image
// (no verdict on the feature); kNoMatch: no convergence, correlation below
// min_zncc, a shift beyond max_shift_px or a warp change beyond
// max_warp_change.
PatchAlignResult AlignPatch(const PatchAnchor& anchor, const cv::Mat& image, const Eigen::Vector2f& initial_pixel,
                            const PatchAlignOptions& options);

}  // namespace mcvo
