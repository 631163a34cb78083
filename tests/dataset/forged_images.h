// Small image files whose headers declare a size their data does not have:
// a PNG whose IHDR (CRC sound) declares any size over a few bytes of pixel
// data, and a JPEG whose frame header (SOF0) is rewritten.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <libdeflate.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace mcvo::testing {

inline void PutBig32(std::vector<uint8_t>* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<uint8_t>(v >> (24 - 8 * i)));
}

inline void PutPngChunk(std::vector<uint8_t>* out, const std::string& type, const std::vector<uint8_t>& body) {
  PutBig32(out, static_cast<uint32_t>(body.size()));
  std::vector<uint8_t> typed(type.begin(), type.end());
  typed.insert(typed.end(), body.begin(), body.end());
  out->insert(out->end(), typed.begin(), typed.end());
  PutBig32(out, libdeflate_crc32(0, typed.data(), typed.size()));
}

// An 8-bit grey PNG declaring width x height, its IDAT one zlib stream of a
// single zero row (far too short for the declared size).
inline std::vector<uint8_t> PngDeclaring(uint32_t width, uint32_t height) {
  std::vector<uint8_t> png = {137, 80, 78, 71, 13, 10, 26, 10};
  std::vector<uint8_t> ihdr;
  PutBig32(&ihdr, width);
  PutBig32(&ihdr, height);
  ihdr.insert(ihdr.end(), {8, 0, 0, 0, 0});  // depth 8, grey, deflate, filter 0, not interlaced
  PutPngChunk(&png, "IHDR", ihdr);
  const std::vector<uint8_t> row(1 + 64, 0);
  libdeflate_compressor* compressor = libdeflate_alloc_compressor(6);
  std::vector<uint8_t> zlib(libdeflate_zlib_compress_bound(compressor, row.size()));
  zlib.resize(libdeflate_zlib_compress(compressor, row.data(), row.size(), zlib.data(), zlib.size()));
  libdeflate_free_compressor(compressor);
  PutPngChunk(&png, "IDAT", zlib);
  PutPngChunk(&png, "IEND", {});
  return png;
}

// A 64 x 48 JPEG (grey or colour) whose SOF0 declares width x height.
inline std::vector<uint8_t> JpegDeclaring(uint16_t width, uint16_t height, bool colour = false) {
  cv::Mat image(48, 64, colour ? CV_8UC3 : CV_8UC1);
  cv::randu(image, 0, 255);
  std::vector<uint8_t> jpeg;
  EXPECT_TRUE(cv::imencode(".jpg", image, jpeg));
  for (size_t i = 2; i + 9 < jpeg.size(); ++i) {
    if (jpeg[i] == 0xFF && jpeg[i + 1] == 0xC0) {  // length (2), precision (1), Y (2), X (2)
      jpeg[i + 5] = static_cast<uint8_t>(height >> 8);
      jpeg[i + 6] = static_cast<uint8_t>(height);
      jpeg[i + 7] = static_cast<uint8_t>(width >> 8);
      jpeg[i + 8] = static_cast<uint8_t>(width);
      return jpeg;
    }
  }
  ADD_FAILURE() << "no SOF0 in OpenCV's JPEG";
  return jpeg;
}

inline void WriteBytes(const std::filesystem::path& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace mcvo::testing
