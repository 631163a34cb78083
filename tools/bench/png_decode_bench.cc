// PNG decoding speed: mcvo's ReadImageFile (DecodePng on libdeflate, see
// include/mcvo/dataset/image_file.h) against what it replaced,
// cv::imread(path, IMREAD_ANYCOLOR | IMREAD_ANYDEPTH), on the PNG files of
// a dataset, one folder (camera) at a time, on one thread. Both read the
// file from the page cache each time. Every decode is compared with
// imread's, byte for byte; a difference is an error (exit 1).
//
//   mcvo_bench_png_decode DIR [FILES_PER_FOLDER] [REPEATS]
//
// DIR is searched recursively for *.png; at most FILES_PER_FOLDER (default
// 20, evenly spaced in name order) per folder, each decoded REPEATS times
// (default 3) by each reader, alternating. Prints one markdown row per
// folder: its layout, the files, the median over files of the mean time per
// decode, and the ratio; then the total over every file timed.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mcvo/dataset/image_file.h"

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string Layout(const cv::Mat& m) {
  const char* depth = m.depth() == CV_8U ? "8-bit" : m.depth() == CV_16U ? "16-bit" : "other";
  return std::to_string(m.cols) + " x " + std::to_string(m.rows) + ", " + std::to_string(m.channels()) +
         " ch, " + depth;
}

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && a.isContinuous() && b.isContinuous() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: mcvo_bench_png_decode DIR [FILES_PER_FOLDER] [REPEATS]\n");
    return 2;
  }
  const fs::path root = argv[1];
  const int per_folder = argc > 2 ? std::max(1, std::atoi(argv[2])) : 20;
  const int repeats = argc > 3 ? std::max(1, std::atoi(argv[3])) : 3;
  std::map<fs::path, std::vector<fs::path>> folders;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(root, ec), end; it != end && !ec; it.increment(ec)) {
    if (it->is_regular_file() && it->path().extension() == ".png")
      folders[it->path().parent_path()].push_back(it->path());
  }
  if (folders.empty()) {
    std::fprintf(stderr, "mcvo_bench_png_decode: no .png files under %s\n", root.string().c_str());
    return 2;
  }
  std::printf(
      "| folder | layout | files | MB per file | ours ms | imread ms | imread / ours | decoded by ours |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|\n");
  double total_ours = 0.0, total_imread = 0.0;
  int total_files = 0;
  for (auto& [folder, files] : folders) {
    std::sort(files.begin(), files.end());
    std::vector<fs::path> chosen;
    const size_t n = std::min(files.size(), static_cast<size_t>(per_folder));
    for (size_t i = 0; i < n; ++i) chosen.push_back(files[i * files.size() / n]);
    std::vector<double> ours_ms, imread_ms;
    double bytes = 0.0;
    int by_ours = 0;
    std::string layout;
    for (const fs::path& file : chosen) {
      bytes += static_cast<double>(fs::file_size(file));
      const cv::Mat reference = cv::imread(file.string(), cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH);
      if (reference.empty()) {
        std::fprintf(stderr, "mcvo_bench_png_decode: OpenCV cannot decode %s\n", file.string().c_str());
        return 1;
      }
      layout = Layout(reference);
      std::vector<uint8_t> data(fs::file_size(file));
      {
        FILE* f = std::fopen(file.string().c_str(), "rb");
        const size_t got = f != nullptr ? std::fread(data.data(), 1, data.size(), f) : 0;
        if (f != nullptr) std::fclose(f);
        if (got != data.size()) return 1;
      }
      by_ours += mcvo::DecodePng(data.data(), data.size()).empty() ? 0 : 1;
      double ours = 0.0, opencv = 0.0;
      for (int r = 0; r < repeats; ++r) {
        auto start = Clock::now();
        const cv::Mat a = mcvo::ReadImageFile(file);
        ours += std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        start = Clock::now();
        const cv::Mat b = cv::imread(file.string(), cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH);
        opencv += std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        if (!Same(a, reference) || !Same(b, reference)) {
          std::fprintf(stderr, "mcvo_bench_png_decode: ReadImageFile differs from cv::imread on %s\n",
                       file.string().c_str());
          return 1;
        }
      }
      ours_ms.push_back(ours / repeats);
      imread_ms.push_back(opencv / repeats);
      total_ours += ours / repeats;
      total_imread += opencv / repeats;
      ++total_files;
    }
    const double ours_median = Median(ours_ms), imread_median = Median(imread_ms);
    std::printf("| %s | %s | %zu | %.2f | %.2f | %.2f | %.2f | %d/%zu |\n",
                fs::relative(folder, root).string().c_str(), layout.c_str(), chosen.size(),
                bytes / chosen.size() / 1e6, ours_median, imread_median, imread_median / ours_median, by_ours,
                chosen.size());
  }
  std::printf(
      "\nAll %d files: ours %.1f ms, imread %.1f ms in all (imread / ours %.2f); identical decodes.\n",
      total_files, total_ours, total_imread, total_imread / total_ours);
  return 0;
}
