// Reading camera images from files: one decode per image, as
// cv::imread(path, IMREAD_ANYCOLOR | IMREAD_ANYDEPTH) gives it, with the PNG
// layouts cameras write decoded by DecodePng.
//
// Why a PNG decoder of our own: libpng (through OpenCV, and libspng alike)
// inflates a PNG row by row through zlib and takes 21 ms for a 1400 x 1400
// grey fisheye image of the KITTI-360 rig, twice what it takes to inflate
// the same data in one call with libdeflate and undo the row filters
// (1.6-2.4 times over 17 cameras, results/png_decode.md). Decoding was the
// largest stage of the frontend (results/throughput.md).
// DecodePng covers only the layouts whose pixels are fixed by the PNG
// standard alone, and gives for them the Mat OpenCV gives, byte for byte
// (tests/dataset/image_file_test.cc, and a differential fuzz target,
// tests/fuzz/png_decode_fuzz.cc); everything else goes to OpenCV.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>

#include <opencv2/core/mat.hpp>

namespace mcvo {

// The decode of a PNG file held in memory, as cv::imdecode(data,
// IMREAD_ANYCOLOR | IMREAD_ANYDEPTH) gives it, for the layouts it covers:
// not interlaced; 8 or 16 bits per sample; grey, grey + alpha, RGB or RGBA;
// no chunks but IHDR, consecutive IDATs, IEND and ancillary ones that
// OpenCV does not apply (tEXt, zTXt, iTXt, tIME, pHYs, gAMA, cHRM, sRGB,
// iCCP, sBIT, bKGD); every CRC, the zlib stream and its
// Adler-32 sound, with no data short or left over. Grey comes out as one
// channel (CV_8UC1 / CV_16UC1), everything else as three channels in BGR
// order, alpha dropped (as OpenCV does for IMREAD_ANYCOLOR); 16-bit samples
// in the machine's byte order. Anything else, a valid PNG of another layout
// or a damaged file, gives an empty Mat: the caller then asks OpenCV, which
// decodes it or says what is wrong. Thread-safe.
cv::Mat DecodePng(const uint8_t* data, size_t size);

// cv::imread(path, IMREAD_ANYCOLOR | IMREAD_ANYDEPTH), with PNG files that
// DecodePng covers decoded by it (the same Mat). Like cv::imread: an empty
// Mat when the file cannot be read or decoded, and cv::Exception where
// OpenCV throws one.
cv::Mat ReadImageFile(const std::filesystem::path& path);

}  // namespace mcvo
