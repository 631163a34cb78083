// ORB descriptors at given pixels (orb_describe.h).
#include "orb_describe.h"

#include <cmath>
#include <cstdint>

namespace mcvo::loop_internal {

float IntensityCentroidAngle(const cv::Mat& image, float x, float y, int radius) {
  const int cx = static_cast<int>(std::lround(x)), cy = static_cast<int>(std::lround(y));
  if (cx - radius < 0 || cy - radius < 0 || cx + radius >= image.cols || cy + radius >= image.rows)
    return 0.0f;
  double m01 = 0.0, m10 = 0.0;
  for (int v = -radius; v <= radius; ++v) {
    const uint8_t* row = image.ptr<uint8_t>(cy + v);
    const int half = static_cast<int>(std::sqrt(static_cast<double>(radius * radius - v * v)));
    for (int u = -half; u <= half; ++u) {
      const double value = row[cx + u];
      m10 += u * value;
      m01 += v * value;
    }
  }
  double angle = std::atan2(m01, m10) * 180.0 / M_PI;
  if (angle < 0.0) angle += 360.0;
  return static_cast<float>(angle);
}

void DescribeOriented(const cv::Ptr<cv::ORB>& orb, const cv::Mat& image,
                      const std::vector<cv::Point2f>& pixels, std::vector<int>* kept, cv::Mat* descriptors) {
  std::vector<cv::KeyPoint> at;
  for (size_t k = 0; k < pixels.size(); ++k) {
    cv::KeyPoint kp(pixels[k], 31.0f);
    kp.octave = 0;
    kp.class_id = static_cast<int>(k);
    kp.angle = IntensityCentroidAngle(image, kp.pt.x, kp.pt.y, 15);
    at.push_back(kp);
  }
  if (at.empty()) return;
  orb->compute(image, at, *descriptors);
  for (const cv::KeyPoint& kp : at) kept->push_back(kp.class_id);
}

}  // namespace mcvo::loop_internal
