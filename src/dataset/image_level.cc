#include "mcvo/dataset/image_level.h"

#include <algorithm>
#include <cstdint>

namespace mcvo {

int LevelForMegapixels(int width, int height, double max_megapixels, int max_level) {
  if (!(max_megapixels > 0.0)) return 0;
  const double max_pixels = max_megapixels * 1e6;
  double pixels = static_cast<double>(width) * height;
  int level = 0;
  while (pixels > max_pixels && level < max_level) {
    ++level;
    pixels /= 4.0;
  }
  return level;
}

cv::Mat CoarseMask(const cv::Mat& mask, int levels) {
  cv::Mat fine = mask;
  for (int level = 0; level < levels; ++level) {
    cv::Mat coarse(cv::Size((fine.cols + 1) / 2, (fine.rows + 1) / 2), CV_8UC1);
    for (int y = 0; y < coarse.rows; ++y) {
      for (int x = 0; x < coarse.cols; ++x) {
        bool usable = true;
        for (int dy = 0; dy < 2; ++dy) {
          for (int dx = 0; dx < 2; ++dx) {
            const int fy = std::min(2 * y + dy, fine.rows - 1), fx = std::min(2 * x + dx, fine.cols - 1);
            usable = usable && fine.at<uint8_t>(fy, fx) != 0;
          }
        }
        coarse.at<uint8_t>(y, x) = usable ? 255 : 0;
      }
    }
    fine = coarse;
  }
  return fine;
}

}  // namespace mcvo
