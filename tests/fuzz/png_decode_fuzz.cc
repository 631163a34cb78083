// libFuzzer target: any bytes -> DecodePng (src/dataset/image_file.cc), the
// PNG decoder of the frontend, differentially against OpenCV. Contract
// (docs/fuzzing.md): DecodePng never crashes, and whenever it gives an
// image, cv::imdecode(IMREAD_ANYCOLOR | IMREAD_ANYDEPTH) gives the same
// type, size and bytes (an empty result, declining, is always allowed: the
// caller then asks OpenCV).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mcvo/dataset/image_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const cv::Mat ours = mcvo::DecodePng(data, size);
  if (ours.empty()) return 0;
  cv::Mat opencv;
  try {
    opencv = cv::imdecode(std::vector<uint8_t>(data, data + size), cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH);
  } catch (const cv::Exception&) {
  }
  if (opencv.empty()) {
    std::fprintf(stderr, "DecodePng decoded a %d x %d image that OpenCV refuses\n", ours.cols, ours.rows);
    std::abort();
  }
  if (ours.type() != opencv.type() || ours.size() != opencv.size() ||
      std::memcmp(ours.data, opencv.data, ours.total() * ours.elemSize()) != 0) {
    std::fprintf(stderr, "DecodePng and OpenCV differ: type %d / %d, %d x %d / %d x %d\n", ours.type(),
                 opencv.type(), ours.cols, ours.rows, opencv.cols, opencv.rows);
    std::abort();
  }
  return 0;
}
