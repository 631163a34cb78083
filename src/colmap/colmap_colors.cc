// Point colours: decoding, 8-bit BGR conversion, bilinear sampling (the
// export's image pass and ColmapColorTable's samples use the same code, so
// a colour is the same whichever of them sampled it).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "colmap_internal.h"
#include "mcvo/colmap/colmap_model.h"
#include "mcvo/dataset/image_container.h"
#include "mcvo/dataset/image_file.h"

namespace mcvo {
namespace colmap_internal {

bool SampleBilinear(const cv::Mat& bgr, const Eigen::Vector2d& pixel, Eigen::Vector3d* rgb) {
  const double fx = std::floor(pixel.x());
  const double fy = std::floor(pixel.y());
  const int x0 = static_cast<int>(fx);
  const int y0 = static_cast<int>(fy);
  if (!(fx >= 0.0 && fy >= 0.0) || x0 + 1 >= bgr.cols || y0 + 1 >= bgr.rows) return false;
  const double ax = pixel.x() - fx;
  const double ay = pixel.y() - fy;
  const cv::Vec3b& p00 = bgr.at<cv::Vec3b>(y0, x0);
  const cv::Vec3b& p01 = bgr.at<cv::Vec3b>(y0, x0 + 1);
  const cv::Vec3b& p10 = bgr.at<cv::Vec3b>(y0 + 1, x0);
  const cv::Vec3b& p11 = bgr.at<cv::Vec3b>(y0 + 1, x0 + 1);
  for (int c = 0; c < 3; ++c) {
    const double top = (1.0 - ax) * p00[c] + ax * p01[c];
    const double bottom = (1.0 - ax) * p10[c] + ax * p11[c];
    (*rgb)[2 - c] = (1.0 - ay) * top + ay * bottom;
  }
  return true;
}

cv::Mat ToBgr8(const cv::Mat& image) {
  cv::Mat eight = image;
  if (image.depth() == CV_16U) {
    image.convertTo(eight, CV_8U, 1.0 / 257.0);
  } else if (image.depth() != CV_8U) {
    image.convertTo(eight, CV_8U);
  }
  cv::Mat bgr;
  if (eight.channels() == 1) {
    cv::cvtColor(eight, bgr, cv::COLOR_GRAY2BGR);
  } else if (eight.channels() == 4) {
    cv::cvtColor(eight, bgr, cv::COLOR_BGRA2BGR);
  } else {
    bgr = eight;
  }
  return bgr;
}

}  // namespace colmap_internal

namespace {

bool PixelLess(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
}

}  // namespace

cv::Mat DecodeColmapColorImage(const std::filesystem::path& path) {
  std::error_code ec;
  // A ROS bag's image is no file: ReadImageFile takes it from the bag (image_container.h).
  if (!std::filesystem::is_regular_file(path, ec) && ImageContainerFile(path).empty()) return cv::Mat();
  try {
    return ReadImageFile(path);
  } catch (const cv::Exception&) {
    return cv::Mat();
  }
}

int ColmapColorSamples::Find(const Eigen::Vector2d& pixel) const {
  const auto it = std::lower_bound(pixels.begin(), pixels.end(), pixel, PixelLess);
  if (it == pixels.end() || *it != pixel) return -1;
  return static_cast<int>(it - pixels.begin());
}

ColmapColorSamples SampleColmapColors(const cv::Mat& decoded, std::vector<Eigen::Vector2d> pixels) {
  std::sort(pixels.begin(), pixels.end(), PixelLess);
  pixels.erase(std::unique(pixels.begin(), pixels.end()), pixels.end());
  ColmapColorSamples out;
  out.colors.assign(pixels.size(), Eigen::Vector3d::Zero());
  out.has_color.assign(pixels.size(), false);
  if (!decoded.empty()) {
    const cv::Mat bgr = colmap_internal::ToBgr8(decoded);
    for (size_t i = 0; i < pixels.size(); ++i) {
      out.has_color[i] = colmap_internal::SampleBilinear(bgr, pixels[i], &out.colors[i]);
    }
  }
  out.pixels = std::move(pixels);
  return out;
}

}  // namespace mcvo
