// DecodePng gives OpenCV's Mat byte for byte on every layout it covers
// (each colour type, depth and row filter, split and annotated data, PNGs
// written by OpenCV at every compression setting), declines everything else
// (other layouts, damaged files) with an empty Mat, and ReadImageFile then
// still gives cv::imread's decode.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <libdeflate.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/dataset/image_file.h"
#include "test_temp_dir.h"

namespace mcvo {
namespace {

constexpr int kReadFlags = cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH;

// A chunk that a test adds to a PNG: its type, body and where it goes.
struct ExtraChunk {
  std::string type;
  std::string body;
  bool after_first_idat = false;
};

struct PngSpec {
  int width = 0;
  int height = 0;
  int depth = 8;   // bits per sample: 8 or 16
  int colour = 0;  // PNG colour type: 0 grey, 2 RGB, 4 grey + alpha, 6 RGBA
  // Filter of row y: filters[y % size]; 0-4 are the standard's, 5 is invalid.
  std::vector<int> filters = {0};
  int idat_chunks = 1;  // the zlib stream split into this many IDATs
  int interlace = 0;
  std::vector<ExtraChunk> extra;
};

int Channels(int colour) { return colour == 0 ? 1 : colour == 2 ? 3 : colour == 4 ? 2 : 4; }

void Put32(std::vector<uint8_t>* out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<uint8_t>(v >> shift));
}

void PutChunk(std::vector<uint8_t>* out, const std::string& type, const std::vector<uint8_t>& body) {
  Put32(out, static_cast<uint32_t>(body.size()));
  std::vector<uint8_t> typed(type.begin(), type.end());
  typed.insert(typed.end(), body.begin(), body.end());
  out->insert(out->end(), typed.begin(), typed.end());
  Put32(out, libdeflate_crc32(0, typed.data(), typed.size()));
}

int Paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
}

// A PNG of `samples` (big-endian rows, no filter bytes) written straight
// from the standard, filters applied forward.
std::vector<uint8_t> EncodePng(const PngSpec& spec, const std::vector<uint8_t>& samples) {
  const int bpp = Channels(spec.colour) * spec.depth / 8;
  const size_t row_bytes = static_cast<size_t>(spec.width) * static_cast<size_t>(bpp);
  std::vector<uint8_t> filtered;
  for (int y = 0; y < spec.height; ++y) {
    const int filter = spec.filters[static_cast<size_t>(y) % spec.filters.size()];
    filtered.push_back(static_cast<uint8_t>(filter));
    const uint8_t* row = &samples[static_cast<size_t>(y) * row_bytes];
    for (size_t x = 0; x < row_bytes; ++x) {
      const int a = x >= static_cast<size_t>(bpp) ? row[x - bpp] : 0;
      const int b = y > 0 ? row[x - row_bytes] : 0;
      const int c = (y > 0 && x >= static_cast<size_t>(bpp)) ? row[x - row_bytes - bpp] : 0;
      int predictor = 0;
      if (filter == 1) predictor = a;
      if (filter == 2) predictor = b;
      if (filter == 3) predictor = (a + b) / 2;
      if (filter == 4) predictor = Paeth(a, b, c);
      filtered.push_back(static_cast<uint8_t>(row[x] - predictor));
    }
  }
  std::unique_ptr<libdeflate_compressor, void (*)(libdeflate_compressor*)> compressor(
      libdeflate_alloc_compressor(6), libdeflate_free_compressor);
  std::vector<uint8_t> zlib(libdeflate_zlib_compress_bound(compressor.get(), filtered.size()));
  zlib.resize(
      libdeflate_zlib_compress(compressor.get(), filtered.data(), filtered.size(), zlib.data(), zlib.size()));

  std::vector<uint8_t> png = {137, 80, 78, 71, 13, 10, 26, 10};
  std::vector<uint8_t> header;
  Put32(&header, static_cast<uint32_t>(spec.width));
  Put32(&header, static_cast<uint32_t>(spec.height));
  header.insert(header.end(), {static_cast<uint8_t>(spec.depth), static_cast<uint8_t>(spec.colour), 0, 0,
                               static_cast<uint8_t>(spec.interlace)});
  PutChunk(&png, "IHDR", header);
  const auto put_extra = [&](bool after) {
    for (const ExtraChunk& chunk : spec.extra) {
      if (chunk.after_first_idat == after) PutChunk(&png, chunk.type, {chunk.body.begin(), chunk.body.end()});
    }
  };
  put_extra(false);
  const size_t piece =
      (zlib.size() + static_cast<size_t>(spec.idat_chunks) - 1) / static_cast<size_t>(spec.idat_chunks);
  for (size_t at = 0; at < zlib.size(); at += piece) {
    const size_t end = std::min(zlib.size(), at + piece);
    PutChunk(
        &png, "IDAT",
        {zlib.begin() + static_cast<std::ptrdiff_t>(at), zlib.begin() + static_cast<std::ptrdiff_t>(end)});
    if (at == 0) put_extra(true);
  }
  PutChunk(&png, "IEND", {});
  return png;
}

// Random samples with smooth parts, so that every filter sees both small
// and wrapping residuals.
std::vector<uint8_t> Samples(const PngSpec& spec, uint32_t seed) {
  std::mt19937 rng(seed);
  const size_t n = static_cast<size_t>(spec.width) * spec.height * Channels(spec.colour) * spec.depth / 8;
  std::vector<uint8_t> samples(n);
  for (size_t i = 0; i < n; ++i) {
    samples[i] = (rng() % 3 == 0) ? static_cast<uint8_t>(rng()) : static_cast<uint8_t>((i * 7) / 5);
  }
  return samples;
}

cv::Mat OpenCvDecode(const std::vector<uint8_t>& png) { return cv::imdecode(png, kReadFlags); }

void ExpectSameMat(const cv::Mat& ours, const cv::Mat& opencv, const std::string& what) {
  ASSERT_FALSE(opencv.empty()) << what;
  ASSERT_FALSE(ours.empty()) << what << ": DecodePng declined it";
  ASSERT_EQ(ours.type(), opencv.type()) << what;
  ASSERT_EQ(ours.size(), opencv.size()) << what;
  ASSERT_TRUE(ours.isContinuous() && opencv.isContinuous());
  const size_t bytes = ours.total() * ours.elemSize();
  EXPECT_EQ(0, std::memcmp(ours.data, opencv.data, bytes)) << what << ": pixels differ";
}

cv::Mat Decode(const std::vector<uint8_t>& png) { return DecodePng(png.data(), png.size()); }

TEST(DecodePng, EqualsOpenCvForEveryColourTypeDepthAndFilter) {
  const std::vector<std::vector<int>> filter_sets = {{0}, {1}, {2}, {3}, {4}, {4, 3, 2, 1, 0, 3, 4}};
  int cases = 0;
  for (int colour : {0, 2, 4, 6}) {
    for (int depth : {8, 16}) {
      for (const std::vector<int>& filters : filter_sets) {
        for (const auto& [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {7, 5}, {33, 19}}) {
          PngSpec spec;
          spec.width = width;
          spec.height = height;
          spec.depth = depth;
          spec.colour = colour;
          spec.filters = filters;
          const std::vector<uint8_t> png = EncodePng(spec, Samples(spec, static_cast<uint32_t>(cases)));
          ExpectSameMat(Decode(png), OpenCvDecode(png),
                        "colour " + std::to_string(colour) + ", depth " + std::to_string(depth) +
                            ", filter " + std::to_string(filters.front()) + ", " + std::to_string(width) +
                            " x " + std::to_string(height));
          ++cases;
        }
      }
    }
  }
  EXPECT_EQ(cases, 4 * 2 * 6 * 3);
}

TEST(DecodePng, GivesOneChannelForGreyAndThreeInBgrOrderOtherwise) {
  PngSpec spec;
  spec.width = 2;
  spec.height = 1;
  spec.colour = 6;  // RGBA
  const std::vector<uint8_t> rgba = {10, 20, 30, 40, 50, 60, 70, 80};
  const cv::Mat bgr = Decode(EncodePng(spec, rgba));
  ASSERT_EQ(bgr.type(), CV_8UC3);
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 1), cv::Vec3b(70, 60, 50));

  spec.colour = 0;
  spec.depth = 16;
  const cv::Mat grey16 = Decode(EncodePng(spec, {0x12, 0x34, 0xab, 0xcd}));
  ASSERT_EQ(grey16.type(), CV_16UC1);
  EXPECT_EQ(grey16.at<uint16_t>(0, 0), 0x1234);
  EXPECT_EQ(grey16.at<uint16_t>(0, 1), 0xabcd);
}

TEST(DecodePng, EqualsOpenCvOnSplitDataAndTextChunks) {
  PngSpec spec;
  spec.width = 40;
  spec.height = 30;
  spec.filters = {1, 4, 3};
  const std::vector<uint8_t> samples = Samples(spec, 7);
  for (int chunks : {2, 5, 64}) {
    spec.idat_chunks = chunks;
    const std::vector<uint8_t> png = EncodePng(spec, samples);
    ExpectSameMat(Decode(png), OpenCvDecode(png), std::to_string(chunks) + " IDAT chunks");
  }
  spec.idat_chunks = 1;
  spec.extra = {{"tEXt", std::string("Software\0mcvo test", 18), false},
                {"pHYs", std::string(9, '\0'), false},
                {"tIME", std::string(7, '\1'), true}};
  const std::vector<uint8_t> png = EncodePng(spec, samples);
  ExpectSameMat(Decode(png), OpenCvDecode(png), "text, pHYs and tIME chunks");
  // Colour-space and display hints: OpenCV does not apply them (a gamma of
  // 1/1.0, sRGB, 4 significant bits, a background, chromaticities).
  for (int colour : {0, 2, 6}) {
    for (int depth : {8, 16}) {
      PngSpec hinted = spec;
      hinted.colour = colour;
      hinted.depth = depth;
      const int channels = colour == 0 ? 1 : 3;
      hinted.extra = {
          {"gAMA", std::string("\0\x01\x86\xa0", 4), false},
          {"sRGB", std::string(1, '\0'), false},
          {"sBIT", std::string(static_cast<size_t>(channels + (colour == 6 ? 1 : 0)), '\4'), false},
          {"cHRM", std::string(32, '\x10'), false},
          {"bKGD", std::string(static_cast<size_t>(2 * channels), '\0'), false}};
      const std::vector<uint8_t> hinted_png = EncodePng(hinted, Samples(hinted, 9));
      ExpectSameMat(Decode(hinted_png), OpenCvDecode(hinted_png),
                    "gAMA, sRGB, sBIT, cHRM, bKGD; colour " + std::to_string(colour) + ", depth " +
                        std::to_string(depth));
    }
  }
}

TEST(DecodePng, EqualsOpenCvOnPngsOpenCvWrites) {
  cv::RNG rng(3);
  cv::Mat grey(37, 53, CV_8UC1), colour(37, 53, CV_8UC3), alpha(37, 53, CV_8UC4), deep(37, 53, CV_16UC1),
      deep_colour(37, 53, CV_16UC3);
  for (cv::Mat* m : {&grey, &colour, &alpha, &deep, &deep_colour}) {
    rng.fill(*m, cv::RNG::UNIFORM, 0, m->depth() == CV_8U ? 256 : 65536);
    cv::GaussianBlur(*m, *m, cv::Size(5, 5), 0.0);  // smooth parts: the encoder picks every filter
  }
  int cases = 0;
  for (const cv::Mat* m : {&grey, &colour, &alpha, &deep, &deep_colour}) {
    for (int level = 0; level <= 9; level += 3) {
      for (int strategy : {cv::IMWRITE_PNG_STRATEGY_DEFAULT, cv::IMWRITE_PNG_STRATEGY_FILTERED,
                           cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY, cv::IMWRITE_PNG_STRATEGY_RLE}) {
        std::vector<uint8_t> png;
        ASSERT_TRUE(cv::imencode(".png", *m, png,
                                 {cv::IMWRITE_PNG_COMPRESSION, level, cv::IMWRITE_PNG_STRATEGY, strategy}));
        ExpectSameMat(Decode(png), OpenCvDecode(png),
                      "type " + std::to_string(m->type()) + ", level " + std::to_string(level) +
                          ", strategy " + std::to_string(strategy));
        ++cases;
      }
    }
  }
  EXPECT_EQ(cases, 5 * 4 * 4);
}

TEST(DecodePng, DeclinesOtherLayoutsAndReadImageFileStillDecodesThem) {
  const std::filesystem::path dir = testing::TestTempDir("image_file_test");
  PngSpec spec;
  spec.width = 9;
  spec.height = 4;
  const std::vector<uint8_t> samples = Samples(spec, 11);
  std::vector<std::pair<std::string, std::vector<uint8_t>>> declined;
  // Chunks that change the pixels OpenCV gives, or might.
  for (const char* type : {"tRNS", "eXIf", "sPLT", "abCd"}) {
    PngSpec with = spec;
    with.extra = {{type, std::string(2, '\1'), false}};
    declined.emplace_back(type, EncodePng(with, samples));
  }
  // A 1-bit image and a palette image, as OpenCV writes them.
  cv::Mat bits(6, 10, CV_8UC1, cv::Scalar(0));
  bits(cv::Rect(0, 0, 5, 6)).setTo(255);
  std::vector<uint8_t> bilevel;
  ASSERT_TRUE(cv::imencode(".png", bits, bilevel, {cv::IMWRITE_PNG_BILEVEL, 1}));
  declined.emplace_back("1-bit", bilevel);
  PngSpec interlaced = spec;
  interlaced.interlace = 1;
  declined.emplace_back("interlaced", EncodePng(interlaced, samples));
  for (const auto& [what, png] : declined) {
    EXPECT_TRUE(Decode(png).empty()) << what;
    const std::filesystem::path path = dir / (what + ".png");
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    const cv::Mat read = ReadImageFile(path), opencv = cv::imread(path.string(), kReadFlags);
    EXPECT_EQ(read.empty(), opencv.empty()) << what;
    if (!opencv.empty()) ExpectSameMat(read, opencv, what + " through ReadImageFile");
  }
}

TEST(DecodePng, DeclinesDamagedFiles) {
  PngSpec spec;
  spec.width = 16;
  spec.height = 8;
  spec.filters = {4};
  const std::vector<uint8_t> good = EncodePng(spec, Samples(spec, 5));
  ASSERT_FALSE(Decode(good).empty());
  EXPECT_TRUE(DecodePng(nullptr, 0).empty());
  EXPECT_TRUE(DecodePng(good.data(), 0).empty());
  EXPECT_TRUE(Decode(std::vector<uint8_t>(good.begin(), good.begin() + 8)).empty());
  for (size_t cut : {size_t{20}, good.size() / 2, good.size() - 1}) {
    EXPECT_TRUE(
        Decode(std::vector<uint8_t>(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(cut))).empty())
        << "cut at " << cut;
  }
  // Any single flipped byte after the signature: a CRC catches it.
  for (size_t at = 8; at < good.size(); at += 3) {
    std::vector<uint8_t> bad = good;
    bad[at] ^= 0x20;
    EXPECT_TRUE(Decode(bad).empty()) << "byte " << at;
  }
  PngSpec invalid_filter = spec;
  invalid_filter.filters = {2, 5};
  EXPECT_TRUE(Decode(EncodePng(invalid_filter, Samples(spec, 5))).empty());
  // Data short of the image or left over after it.
  std::vector<uint8_t> claims_more = EncodePng(spec, Samples(spec, 5));
  claims_more[23] = 9;  // IHDR height 8 -> 9: the data is one row short
  const uint32_t crc = libdeflate_crc32(0, &claims_more[12], 17);
  for (int i = 0; i < 4; ++i) claims_more[29 + i] = static_cast<uint8_t>(crc >> (24 - 8 * i));
  EXPECT_TRUE(Decode(claims_more).empty());
  claims_more[23] = 7;  // height 7: a row left over
  const uint32_t crc7 = libdeflate_crc32(0, &claims_more[12], 17);
  for (int i = 0; i < 4; ++i) claims_more[29 + i] = static_cast<uint8_t>(crc7 >> (24 - 8 * i));
  EXPECT_TRUE(Decode(claims_more).empty());
  EXPECT_TRUE(Decode({'n', 'o', 't', ' ', 'a', ' ', 'p', 'n', 'g'}).empty());
}

TEST(ReadImageFile, EqualsImreadForPngsAndOtherFormats) {
  const std::filesystem::path dir = testing::TestTempDir("image_file_test");
  cv::Mat image(21, 34, CV_8UC3);
  cv::RNG(9).fill(image, cv::RNG::UNIFORM, 0, 256);
  for (const char* name : {"a.png", "b.jpg", "c.bmp"}) {
    const std::filesystem::path path = dir / name;
    ASSERT_TRUE(cv::imwrite(path.string(), image));
    ExpectSameMat(ReadImageFile(path), cv::imread(path.string(), kReadFlags), name);
  }
  EXPECT_TRUE(ReadImageFile(dir / "missing.png").empty());
  const std::filesystem::path empty = dir / "empty.png";
  std::ofstream(empty).close();
  EXPECT_TRUE(ReadImageFile(empty).empty());
}

}  // namespace
}  // namespace mcvo
