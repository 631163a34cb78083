// A colour copy of a generic-format dataset, for tools/bench_throughput.sh:
// real rigs (KITTI-360's cameras among them) record colour PNGs, which cost
// more to decode than the synthetic renderer's grey ones. Every image under
// SRC/images becomes a 3-channel 8-bit PNG under DST/images, its channels
// three different affine maps of the grey value (R = g, G = 0.92 g + 12,
// B = 0.8 g + 25, rounded); every other file of SRC is copied. The
// timing of a run on the copy is what decoding colour adds; its accuracy is
// not a measurement of anything (the tint is not a real colour scene).
//
//   mcvo_bench_colourise SRC DST     (DST must not exist)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace fs = std::filesystem;

namespace {

cv::Mat Colourise(const cv::Mat& grey) {
  cv::Mat bgr(grey.size(), CV_8UC3);
  for (int y = 0; y < grey.rows; ++y) {
    const uint8_t* g = grey.ptr<uint8_t>(y);
    cv::Vec3b* out = bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < grey.cols; ++x) {
      const double v = g[x];
      auto clamp8 = [](double c) { return static_cast<uint8_t>(std::clamp(std::lround(c), 0L, 255L)); };
      out[x] = cv::Vec3b(clamp8(0.8 * v + 25.0), clamp8(0.92 * v + 12.0), g[x]);
    }
  }
  return bgr;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: mcvo_bench_colourise SRC DST\n");
    return 2;
  }
  const fs::path src = argv[1], dst = argv[2];
  std::error_code ec;
  if (!fs::is_directory(src / "images", ec)) {
    std::fprintf(stderr, "%s: no images/ folder (a generic-format dataset, mcvo synth's output)\n",
                 src.c_str());
    return 1;
  }
  if (fs::exists(dst, ec)) {
    std::fprintf(stderr, "%s: exists\n", dst.c_str());
    return 1;
  }
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(src)) {
    if (e.is_regular_file()) files.push_back(fs::relative(e.path(), src));
  }
  std::sort(files.begin(), files.end());
  int images = 0;
  for (const fs::path& rel : files) {
    fs::create_directories((dst / rel).parent_path());
    const bool is_image = *rel.begin() == "images" && rel.extension() == ".png";
    if (!is_image) {
      fs::copy_file(src / rel, dst / rel);
      continue;
    }
    const cv::Mat grey = cv::imread((src / rel).string(), cv::IMREAD_GRAYSCALE);
    if (grey.empty() || !cv::imwrite((dst / rel).string(), Colourise(grey))) {
      std::fprintf(stderr, "%s: cannot convert\n", (src / rel).c_str());
      return 1;
    }
    ++images;
  }
  std::printf("%d images in colour, %zu other files copied, into %s\n", images, files.size() - images,
              dst.c_str());
  return 0;
}
