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
#include <optional>

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

// What a file's header declares, read without decoding the pixels.
struct ImageHeader {
  const char* format = "";  // "png", "jpeg", "pnm", "bmp" or "tiff"
  int64_t width = 0;
  int64_t height = 0;
  int bit_depth = 0;  // bits per sample (per pixel for palette BMPs)
  int channels = 0;   // samples per pixel as stored (a palette: 1)
};

// The header of a PNG (IHDR, its CRC sound), JPEG (the first SOFn marker),
// PNM (P1-P6), BMP or TIFF (the first IFD) file, identified by its first
// bytes as OpenCV identifies them, read from the few bytes before the pixel
// data: so that a file's size can be checked before a decoder allocates the
// image. std::nullopt for other formats, a JPEG whose height comes later
// (DNL), BigTIFF, and headers that are damaged or cut short (the decoder then
// says what is wrong). The decode of a JPEG or TIFF file may be turned by
// its EXIF orientation (cv::imread applies it): width and height are then
// swapped in the decode.
std::optional<ImageHeader> ReadImageHeader(const std::filesystem::path& path);

// cv::imread(path, IMREAD_ANYCOLOR | IMREAD_ANYDEPTH), with PNG files that
// DecodePng covers decoded by it (the same Mat). Like cv::imread: an empty
// Mat when the file cannot be read or decoded, and cv::Exception where
// OpenCV throws one. A member of a registered image container (a ROS bag's
// image, mcvo/dataset/image_container.h) is decoded by the container, which
// throws InputError naming the container and member when it cannot.
cv::Mat ReadImageFile(const std::filesystem::path& path);

}  // namespace mcvo
