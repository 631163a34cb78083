// DecodePng and ReadImageFile (mcvo/dataset/image_file.h).
//
// The PNG standard (ISO/IEC 15948, W3C PNG 2nd edition) fixes the pixels of
// the layouts covered here: the concatenated IDAT data is one zlib stream of
// `height` scanlines, each a filter-type byte and `width * bpp` filtered
// bytes, with bpp the bytes per pixel (channels x bytes per sample). Filters
// (section 9): None, Sub (a = the byte bpp to the left), Up (b = the byte
// above), Average (floor((a + b) / 2)) and Paeth (of a, b and c = the byte
// above a), every sum modulo 256; bytes left of the row or above the first
// row are 0. Samples are big-endian.
#include "mcvo/dataset/image_file.h"

#include "mcvo/dataset/image_container.h"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include <libdeflate.h>
#include <opencv2/imgcodecs.hpp>

namespace mcvo {
namespace {

constexpr std::array<uint8_t, 8> kSignature = {137, 80, 78, 71, 13, 10, 26, 10};
// Beyond this many bytes of filtered data (or pixels) OpenCV decides: it has
// its own limits on image size (CV_IO_MAX_IMAGE_PIXELS).
constexpr uint64_t kMaxFilteredBytes = uint64_t{1} << 30;
constexpr uint64_t kMaxPixels = uint64_t{1} << 28;

uint32_t BigEndian32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

bool ChunkIs(const uint8_t* type, const char* name) { return std::memcmp(type, name, 4) == 0; }

// Ancillary chunks that do not change the pixels OpenCV decodes: text,
// time and pixel size, and the colour-space and display hints (gamma,
// chromaticities, sRGB intent, ICC profile, significant bits, background)
// that libpng applies only when asked to (png_set_gamma, png_set_shift,
// png_set_background), which OpenCV's decoder never does. Not here: tRNS
// (transparency, which may become an alpha channel) and eXIf (orientation).
bool IsInformational(const uint8_t* type) {
  static constexpr const char* kTypes[] = {"tEXt", "zTXt", "iTXt", "tIME", "pHYs", "gAMA",
                                           "cHRM", "sRGB", "iCCP", "sBIT", "bKGD"};
  return std::any_of(std::begin(kTypes), std::end(kTypes),
                     [&](const char* name) { return ChunkIs(type, name); });
}

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

libdeflate_decompressor* ThreadDecompressor() {
  thread_local std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> decompressor(
      libdeflate_alloc_decompressor());
  return decompressor.get();
}

struct Header {
  uint32_t width = 0;
  uint32_t height = 0;
  int bytes_per_sample = 1;
  int channels = 1;  // 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA
};

// IHDR of a covered layout; false for anything else.
bool ParseHeader(const uint8_t* data, uint32_t length, Header* header) {
  if (length != 13) return false;
  header->width = BigEndian32(data);
  header->height = BigEndian32(data + 4);
  const uint8_t depth = data[8], colour = data[9];
  // Compression method 0, filter method 0, no interlacing.
  if (data[10] != 0 || data[11] != 0 || data[12] != 0) return false;
  // libpng's default limit on either side (PNG_USER_WIDTH_MAX, _HEIGHT_MAX):
  // larger images are OpenCV's to refuse.
  constexpr uint32_t kMaxSide = 1000000;
  if (header->width == 0 || header->height == 0 || header->width > kMaxSide || header->height > kMaxSide)
    return false;
  if (depth != 8 && depth != 16) return false;
  header->bytes_per_sample = depth / 8;
  switch (colour) {
    case 0:
      header->channels = 1;
      break;
    case 2:
      header->channels = 3;
      break;
    case 4:
      header->channels = 2;
      break;
    case 6:
      header->channels = 4;
      break;
    default:
      return false;  // palette
  }
  return true;
}

// Undoes one row's filter in place. row: the filtered bytes, becoming the
// reconstructed ones; prior: the reconstructed row above (zeros for the
// first row); bytes: a multiple of BPP. Sub, Average and Paeth are serial
// along the row, one chain per byte of a pixel: BPP is a template argument
// so that each chain's left byte (a) and upper-left byte (c) stay in
// registers (through memory, each byte would wait for the store of the one
// before it).
template <int BPP>
bool Unfilter(int filter, uint8_t* row, const uint8_t* prior, size_t bytes) {
  const auto paeth = [](int a, int b, int c) {
    const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
    // Two selects rather than nested branches: conditional moves, no
    // mispredictions on the serial chain.
    const int b_or_c = pb <= pc ? b : c;
    return ((pa <= pb) & (pa <= pc)) ? a : b_or_c;
  };
  std::array<int, BPP> a{}, c{};  // left of the row: 0
  switch (filter) {
    case 0:
      return true;
    case 1:
      for (size_t x = 0; x < bytes; x += BPP) {
        for (int k = 0; k < BPP; ++k) row[x + k] = static_cast<uint8_t>(a[k] = (row[x + k] + a[k]) & 0xff);
      }
      return true;
    case 2:
      for (size_t x = 0; x < bytes; ++x) row[x] = static_cast<uint8_t>(row[x] + prior[x]);
      return true;
    case 3:
      for (size_t x = 0; x < bytes; x += BPP) {
        for (int k = 0; k < BPP; ++k) {
          row[x + k] = static_cast<uint8_t>(a[k] = (row[x + k] + ((a[k] + prior[x + k]) >> 1)) & 0xff);
        }
      }
      return true;
    case 4:
      for (size_t x = 0; x < bytes; x += BPP) {
        for (int k = 0; k < BPP; ++k) {
          const int b = prior[x + k];
          row[x + k] = static_cast<uint8_t>(a[k] = (row[x + k] + paeth(a[k], b, c[k])) & 0xff);
          c[k] = b;
        }
      }
      return true;
    default:
      return false;
  }
}

bool UnfilterRow(int bpp, int filter, uint8_t* row, const uint8_t* prior, size_t bytes) {
  switch (bpp) {
    case 1:
      return Unfilter<1>(filter, row, prior, bytes);
    case 2:
      return Unfilter<2>(filter, row, prior, bytes);
    case 3:
      return Unfilter<3>(filter, row, prior, bytes);
    case 4:
      return Unfilter<4>(filter, row, prior, bytes);
    case 6:
      return Unfilter<6>(filter, row, prior, bytes);
    case 8:
      return Unfilter<8>(filter, row, prior, bytes);
    default:
      return false;
  }
}

// The reconstructed big-endian samples of one row -> the Mat's row: grey
// as is, colour to BGR, alpha dropped, grey + alpha to three equal channels.
template <typename T>
void ConvertRow(const uint8_t* in, T* out, uint32_t width, int channels) {
  constexpr int kBytes = static_cast<int>(sizeof(T));
  const auto sample = [&](uint32_t x, int c) -> T {
    const uint8_t* p = in + (static_cast<size_t>(x) * channels + c) * kBytes;
    if constexpr (kBytes == 1) {
      return *p;
    } else {
      return static_cast<T>((p[0] << 8) | p[1]);
    }
  };
  for (uint32_t x = 0; x < width; ++x) {
    if (channels == 1) {
      out[x] = sample(x, 0);
    } else if (channels == 2) {
      const T grey = sample(x, 0);
      out[3 * x] = out[3 * x + 1] = out[3 * x + 2] = grey;
    } else {
      out[3 * x] = sample(x, 2);
      out[3 * x + 1] = sample(x, 1);
      out[3 * x + 2] = sample(x, 0);
    }
  }
}

// The concatenated IDAT data and the header, when the chunk sequence is one
// DecodePng covers.
bool ReadChunks(const uint8_t* data, size_t size, Header* header, std::vector<uint8_t>* idat) {
  if (size < kSignature.size() || std::memcmp(data, kSignature.data(), kSignature.size()) != 0) return false;
  size_t at = kSignature.size();
  bool have_header = false, in_idat = false, idat_done = false;
  while (true) {
    if (size - at < 12) return false;  // no IEND
    const uint32_t length = BigEndian32(data + at);
    if (length > 0x7fffffffu || size - at - 12 < length) return false;
    const uint8_t* type = data + at + 4;
    const uint8_t* body = type + 4;
    if (libdeflate_crc32(0, type, size_t{length} + 4) != BigEndian32(body + length)) return false;
    at += size_t{length} + 12;
    if (!have_header) {
      if (!ChunkIs(type, "IHDR") || !ParseHeader(body, length, header)) return false;
      have_header = true;
    } else if (ChunkIs(type, "IDAT")) {
      if (idat_done) return false;  // IDATs must be consecutive
      in_idat = true;
      idat->insert(idat->end(), body, body + length);
    } else if (ChunkIs(type, "IEND")) {
      return in_idat || idat_done;
    } else if (IsInformational(type)) {
      if (in_idat) {
        in_idat = false;
        idat_done = true;
      }
    } else {
      return false;  // a chunk that may change the pixels (PLTE, tRNS, eXIf, ...) or an unknown one
    }
  }
}

}  // namespace

cv::Mat DecodePng(const uint8_t* data, size_t size) {
  if (data == nullptr) return cv::Mat();
  // Buffers kept by each decoding thread from image to image: allocating
  // (and zeroing) megabytes per image costs a page fault per 4 KB.
  thread_local std::vector<uint8_t> idat, filtered;
  struct Release {
    ~Release() {
      constexpr size_t kKeepBytes = size_t{64} << 20;
      if (idat.capacity() > kKeepBytes) std::vector<uint8_t>().swap(idat);
      if (filtered.capacity() > kKeepBytes) std::vector<uint8_t>().swap(filtered);
    }
  } release;
  idat.clear();
  Header header;
  if (!ReadChunks(data, size, &header, &idat)) return cv::Mat();
  const int bpp = header.channels * header.bytes_per_sample;
  const uint64_t row_bytes = uint64_t{header.width} * static_cast<uint64_t>(bpp);
  const uint64_t filtered_bytes = uint64_t{header.height} * (row_bytes + 1);
  if (filtered_bytes > kMaxFilteredBytes || uint64_t{header.width} * header.height > kMaxPixels)
    return cv::Mat();

  if (filtered.size() < filtered_bytes) filtered.resize(static_cast<size_t>(filtered_bytes));
  size_t used_in = 0, produced = 0;
  const libdeflate_result result =
      libdeflate_zlib_decompress_ex(ThreadDecompressor(), idat.data(), idat.size(), filtered.data(),
                                    static_cast<size_t>(filtered_bytes), &used_in, &produced);
  if (result != LIBDEFLATE_SUCCESS || used_in != idat.size() || produced != filtered_bytes) return cv::Mat();

  const size_t stride = static_cast<size_t>(row_bytes);
  const std::vector<uint8_t> zeros(stride, 0);
  const int depth = header.bytes_per_sample == 1 ? CV_8U : CV_16U;
  cv::Mat image(static_cast<int>(header.height), static_cast<int>(header.width),
                CV_MAKETYPE(depth, header.channels == 1 ? 1 : 3));
  // 8-bit grey rows are reconstructed in the image itself; other layouts in
  // the filtered buffer (each row after its filter byte), then converted.
  const bool direct = header.channels == 1 && header.bytes_per_sample == 1;
  const uint8_t* prior = zeros.data();
  for (uint32_t y = 0; y < header.height; ++y) {
    uint8_t* in = filtered.data() + static_cast<size_t>(y) * (stride + 1);
    uint8_t* row = in + 1;
    if (direct) {
      uint8_t* out = image.ptr<uint8_t>(static_cast<int>(y));
      std::memcpy(out, row, stride);
      row = out;
    }
    if (!UnfilterRow(bpp, in[0], row, prior, stride)) return cv::Mat();
    prior = row;
  }
  if (!direct) {
    for (uint32_t y = 0; y < header.height; ++y) {
      const uint8_t* row = filtered.data() + static_cast<size_t>(y) * (stride + 1) + 1;
      if (depth == CV_8U) {
        ConvertRow(row, image.ptr<uint8_t>(static_cast<int>(y)), header.width, header.channels);
      } else {
        ConvertRow(row, image.ptr<uint16_t>(static_cast<int>(y)), header.width, header.channels);
      }
    }
  }
  return image;
}

cv::Mat ReadImageFile(const std::filesystem::path& path) {
  bool member = false;
  cv::Mat from_container = DecodeContainerImage(path, &member);
  if (member) return from_container;
  {
    std::ifstream in(path, std::ios::binary);
    if (in) {
      std::array<char, kSignature.size()> head{};
      in.read(head.data(), static_cast<std::streamsize>(head.size()));
      if (in.gcount() == static_cast<std::streamsize>(head.size()) &&
          std::memcmp(head.data(), kSignature.data(), head.size()) == 0) {
        in.seekg(0, std::ios::end);
        const std::streamoff size = in.tellg();
        if (size > 0 && static_cast<uint64_t>(size) <= kMaxFilteredBytes) {
          thread_local std::vector<uint8_t> bytes;  // kept from file to file, as DecodePng's buffers
          if (bytes.size() < static_cast<size_t>(size)) bytes.resize(static_cast<size_t>(size));
          in.seekg(0, std::ios::beg);
          if (in.read(reinterpret_cast<char*>(bytes.data()), size)) {
            cv::Mat image = DecodePng(bytes.data(), static_cast<size_t>(size));
            if (bytes.capacity() > (size_t{64} << 20)) std::vector<uint8_t>().swap(bytes);
            if (!image.empty()) return image;
          }
        }
      }
    }
  }
  return cv::imread(path.string(), cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH);
}

}  // namespace mcvo
