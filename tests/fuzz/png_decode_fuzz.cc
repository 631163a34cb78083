// libFuzzer target: DecodePng (src/dataset/image_file.cc), the PNG decoder
// of the frontend, differentially against OpenCV. Contract
// (docs/fuzzing.md): DecodePng never crashes, and whenever it gives an
// image, cv::imdecode(IMREAD_ANYCOLOR | IMREAD_ANYDEPTH) gives the same
// type, size and bytes (an empty result, declining, is always allowed: the
// caller then asks OpenCV).
//
// Mutated bytes almost never keep a PNG's CRCs and zlib stream valid, which
// would stop the fuzzer at the first check. So the first input byte picks
// how the rest becomes a PNG:
//   even: the bytes as they are, every chunk's CRC then recomputed (chunk
//         order, lengths, header fields, the compressed stream);
//   odd:  a header (width, height, depth, colour type, interlace, and
//         which chunks to add) and the filtered scanlines themselves,
//         filter bytes included, deflated here into a valid stream, cut
//         short or given extra rows when the header says so, with text,
//         gamma and other colour-space chunks (the row filters, the pixel
//         layouts, the ancillary chunks DecodePng accepts).
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <libdeflate.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mcvo/dataset/image_file.h"

namespace {

uint32_t BigEndian32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

void Put32(std::vector<uint8_t>* out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<uint8_t>(v >> shift));
}

void PutChunk(std::vector<uint8_t>* out, const char* type, const std::vector<uint8_t>& body) {
  Put32(out, static_cast<uint32_t>(body.size()));
  const size_t start = out->size();
  out->insert(out->end(), type, type + 4);
  out->insert(out->end(), body.begin(), body.end());
  Put32(out, libdeflate_crc32(0, out->data() + start, body.size() + 4));
}

// The input with each chunk's CRC made right, as far as the chunks parse.
std::vector<uint8_t> WithFixedCrcs(const uint8_t* data, size_t size) {
  std::vector<uint8_t> png(data, data + size);
  size_t at = 8;
  while (at + 12 <= png.size()) {
    const uint32_t length = BigEndian32(&png[at]);
    if (length > png.size() - at - 12) break;
    const uint32_t crc = libdeflate_crc32(0, &png[at + 4], size_t{length} + 4);
    for (int i = 0; i < 4; ++i) png[at + 8 + length + i] = static_cast<uint8_t>(crc >> (24 - 8 * i));
    at += size_t{length} + 12;
  }
  return png;
}

// A PNG built from a small header and the filtered scanlines.
std::vector<uint8_t> Built(const uint8_t* data, size_t size) {
  if (size < 6) return {};
  const uint32_t width = 1 + data[0] % 64, height = 1 + data[1] % 64;
  const uint8_t depth = (data[2] & 1) ? 16 : 8;
  static const uint8_t kColours[] = {0, 2, 4, 6, 3, 0, 2, 6};
  const uint8_t colour = kColours[(data[2] >> 1) & 7];
  const uint8_t interlace = (data[2] >> 4) & 1;
  const uint8_t flags = data[3];
  const int level = data[4] % 13;
  const int hints = data[4] / 13;  // which colour-space / display chunks to add
  const int channels = colour == 0 ? 1 : colour == 2 ? 3 : colour == 4 ? 2 : colour == 6 ? 4 : 1;
  const size_t row = 1 + width * static_cast<size_t>(channels) * (depth / 8);
  // Rows: exactly the image's, one short or one more when the flags say so.
  size_t rows = height;
  if ((flags & 3) == 1 && rows > 1) rows -= 1;
  if ((flags & 3) == 2) rows += 1;
  std::vector<uint8_t> filtered(rows * row, 0);
  const size_t payload = size - 5;
  for (size_t i = 0; i < filtered.size() && payload > 0; ++i) filtered[i] = data[5 + i % payload];

  std::unique_ptr<libdeflate_compressor, void (*)(libdeflate_compressor*)> compressor(
      libdeflate_alloc_compressor(level), libdeflate_free_compressor);
  if (!compressor) return {};
  std::vector<uint8_t> zlib(libdeflate_zlib_compress_bound(compressor.get(), filtered.size()));
  zlib.resize(
      libdeflate_zlib_compress(compressor.get(), filtered.data(), filtered.size(), zlib.data(), zlib.size()));
  if ((flags & 4) && !zlib.empty()) zlib.pop_back();  // a damaged Adler-32
  if (flags & 8) zlib.push_back(0);                   // data after the stream

  std::vector<uint8_t> png = {137, 80, 78, 71, 13, 10, 26, 10};
  std::vector<uint8_t> header;
  Put32(&header, width);
  Put32(&header, height);
  header.insert(header.end(), {depth, colour, 0, 0, interlace});
  PutChunk(&png, "IHDR", header);
  if (flags & 16) PutChunk(&png, "tEXt", {'k', 0, 'v'});
  if (flags & 32) PutChunk(&png, "gAMA", {0, 0, 0xb1, 0x8f});
  // Their contents from the payload: valid or not, OpenCV must not apply them.
  const auto payload_bytes = [&](size_t n) {
    std::vector<uint8_t> bytes(n, 0);
    for (size_t i = 0; i < n && size > 5; ++i) bytes[i] = data[5 + (i * 7) % (size - 5)];
    return bytes;
  };
  if (hints & 1) PutChunk(&png, "sRGB", payload_bytes(1));
  if (hints & 2) PutChunk(&png, "cHRM", payload_bytes(32));
  if (hints & 4) PutChunk(&png, "sBIT", payload_bytes(static_cast<size_t>(channels)));
  if (hints & 8) PutChunk(&png, "bKGD", payload_bytes(colour == 0 || colour == 4 ? 2 : 6));
  if (hints & 16) PutChunk(&png, "iCCP", payload_bytes(24));
  if (colour == 3) PutChunk(&png, "PLTE", {0, 0, 0, 255, 255, 255});
  const size_t pieces = 1 + (flags >> 6);
  const size_t piece = std::max<size_t>(1, (zlib.size() + pieces - 1) / pieces);
  for (size_t at = 0; at < zlib.size(); at += piece) {
    PutChunk(&png, "IDAT",
             {zlib.begin() + static_cast<std::ptrdiff_t>(at),
              zlib.begin() + static_cast<std::ptrdiff_t>(std::min(zlib.size(), at + piece))});
  }
  PutChunk(&png, "IEND", {});
  return png;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::vector<uint8_t> png =
      (data[0] & 1) ? Built(data + 1, size - 1) : WithFixedCrcs(data + 1, size - 1);
  if (png.empty()) return 0;
  const cv::Mat ours = mcvo::DecodePng(png.data(), png.size());
  if (ours.empty()) return 0;
  cv::Mat opencv;
  try {
    opencv = cv::imdecode(png, cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH);
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
