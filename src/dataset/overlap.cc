#include "mcvo/dataset/overlap.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <opencv2/core.hpp>

#include "mcvo/util/error.h"

namespace mcvo {

namespace {

// True when the mask is empty or its pixel nearest to `pixel` is non-zero.
bool MaskValid(const cv::Mat& mask, const Eigen::Vector2d& pixel) {
  if (mask.empty()) return true;
  const int x = std::clamp(static_cast<int>(std::lround(pixel.x())), 0, mask.cols - 1);
  const int y = std::clamp(static_cast<int>(std::lround(pixel.y())), 0, mask.rows - 1);
  return mask.at<uint8_t>(y, x) != 0;
}

void CheckMask(const cv::Mat& mask, const Camera& camera) {
  MCVO_CHECK_MSG(
      mask.empty() || (mask.type() == CV_8UC1 && mask.cols == camera.width && mask.rows == camera.height),
      "mask of camera ", camera.name, " does not match its image size");
}

}  // namespace

double ViewOverlap(const Camera& a, const Camera& b, double depth_m) {
  return ViewOverlap(a, b, depth_m, cv::Mat(), cv::Mat());
}

double ViewOverlap(const Camera& a, const Camera& b, double depth_m, const cv::Mat& mask_a,
                   const cv::Mat& mask_b) {
  MCVO_CHECK_MSG(depth_m > 0.0, "depth_m must be > 0, got ", depth_m);
  CheckMask(mask_a, a);
  CheckMask(mask_b, b);
  const Rigid3d b_from_a = b.cam_from_rig * a.cam_from_rig.Inverse();
  int valid = 0;
  int seen = 0;
  for (int iy = 0; iy < kViewOverlapGrid; ++iy) {
    for (int ix = 0; ix < kViewOverlapGrid; ++ix) {
      // Cell centres of a regular grid over the image, in pixel-centre coordinates.
      const Eigen::Vector2d pixel((ix + 0.5) * a.width / kViewOverlapGrid - 0.5,
                                  (iy + 0.5) * a.height / kViewOverlapGrid - 0.5);
      const std::optional<Eigen::Vector3d> bearing = a.Unproject(pixel);
      if (!bearing || !MaskValid(mask_a, pixel)) continue;
      ++valid;
      const Eigen::Vector3d point_in_b = b_from_a * (bearing->normalized() * depth_m);
      const std::optional<Eigen::Vector2d> pixel_in_b = b.Project(point_in_b);
      if (pixel_in_b && b.IsInImage(*pixel_in_b) && b.Unproject(*pixel_in_b) &&
          MaskValid(mask_b, *pixel_in_b))
        ++seen;
    }
  }
  return valid == 0 ? 0.0 : static_cast<double>(seen) / valid;
}

}  // namespace mcvo
