// ReadImageHeader (mcvo/dataset/image_file.h): the width, height, bit depth
// and channels a file declares, from the bytes before its pixel data.
// Layouts: PNG (ISO/IEC 15948: the signature, then IHDR as the first chunk),
// JPEG (ITU T.81 B.2: marker segments after SOI up to the first SOFn frame
// header: precision P, lines Y, samples per line X, components Nf), Netpbm
// PNM (magic, then width, height and maxval as ASCII decimals between
// whitespace and # comments), BMP (the 14-byte file header, then a
// BITMAPCOREHEADER of 12 bytes or a BITMAPINFOHEADER of 40 or more), TIFF 6.0
// (the 8-byte header, then the first IFD's ImageWidth, ImageLength,
// BitsPerSample and SamplesPerPixel entries).
#include <algorithm>
#include <array>
#include <cctype>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <libdeflate.h>

#include "mcvo/dataset/image_file.h"

namespace mcvo {
namespace {

// Random access to the file's bytes, each read bounded by the file's size.
class FileBytes {
 public:
  explicit FileBytes(const std::filesystem::path& path) : in_(path, std::ios::binary) {
    if (!in_) return;
    in_.seekg(0, std::ios::end);
    const std::streamoff size = in_.tellg();
    size_ = size > 0 ? static_cast<uint64_t>(size) : 0;
  }
  bool Read(uint64_t at, size_t n, uint8_t* out) {
    if (!in_ || at > size_ || size_ - at < n) return false;
    in_.seekg(static_cast<std::streamoff>(at), std::ios::beg);
    return static_cast<bool>(in_.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n)));
  }
  uint64_t size() const { return size_; }

 private:
  std::ifstream in_;
  uint64_t size_ = 0;
};

uint32_t Big16(const uint8_t* p) { return (uint32_t{p[0]} << 8) | p[1]; }
uint32_t Big32(const uint8_t* p) { return (Big16(p) << 16) | Big16(p + 2); }
uint32_t Little16(const uint8_t* p) { return (uint32_t{p[1]} << 8) | p[0]; }
uint32_t Little32(const uint8_t* p) { return (Little16(p + 2) << 16) | Little16(p); }

std::optional<ImageHeader> PngHeader(FileBytes& file) {
  std::array<uint8_t, 33> b{};  // signature, IHDR length, type, 13 bytes, CRC
  if (!file.Read(0, b.size(), b.data())) return std::nullopt;
  if (Big32(b.data() + 8) != 13 || std::memcmp(b.data() + 12, "IHDR", 4) != 0) return std::nullopt;
  if (libdeflate_crc32(0, b.data() + 12, 17) != Big32(b.data() + 29)) return std::nullopt;
  ImageHeader header;
  header.format = "png";
  header.width = Big32(b.data() + 16);
  header.height = Big32(b.data() + 20);
  header.bit_depth = b[24];
  static constexpr int kChannels[] = {1, 0, 3, 1, 2, 0, 4};  // by colour type
  if (b[25] > 6 || kChannels[b[25]] == 0) return std::nullopt;
  header.channels = kChannels[b[25]];
  return header;
}

bool IsJpegFrameHeader(uint8_t marker) {
  // SOF0-SOF15 but DHT (C4), JPG (C8) and DAC (CC).
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
}

std::optional<ImageHeader> JpegHeader(FileBytes& file) {
  uint64_t at = 2;  // after SOI
  for (int segments = 0; segments < 100000; ++segments) {
    std::array<uint8_t, 2> m{};
    if (!file.Read(at, 2, m.data()) || m[0] != 0xFF) return std::nullopt;
    if (m[1] == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    at += 2;
    if (m[1] == 0x01 || (m[1] >= 0xD0 && m[1] <= 0xD8)) continue;  // TEM, RSTn, SOI: no length
    if (m[1] == 0xD9 || m[1] == 0xDA) return std::nullopt;          // EOI or scan data before a frame header
    std::array<uint8_t, 8> s{};  // length, and a frame header's P, Y, X, Nf
    if (!file.Read(at, 2, s.data())) return std::nullopt;
    const uint32_t length = Big16(s.data());
    if (length < 2) return std::nullopt;
    if (IsJpegFrameHeader(m[1])) {
      if (length < 8 || !file.Read(at, 8, s.data())) return std::nullopt;
      ImageHeader header;
      header.format = "jpeg";
      header.bit_depth = s[2];
      header.height = Big16(s.data() + 3);
      header.width = Big16(s.data() + 5);
      header.channels = s[7];
      if (header.height == 0) return std::nullopt;  // given by a DNL segment after the first scan
      return header;
    }
    at += length;
  }
  return std::nullopt;
}

std::optional<ImageHeader> PnmHeader(FileBytes& file, uint8_t kind) {
  std::vector<uint8_t> text(static_cast<size_t>(std::min<uint64_t>(file.size(), 4096)));
  if (!file.Read(0, text.size(), text.data())) return std::nullopt;
  const bool bitmap = kind == '1' || kind == '4';
  size_t at = 2;
  int64_t values[3] = {0, 0, 0};  // width, height, maxval (none in a bitmap)
  for (int v = 0; v < (bitmap ? 2 : 3); ++v) {
    while (at < text.size() && (std::isspace(text[at]) || text[at] == '#')) {
      if (text[at] == '#') {
        while (at < text.size() && text[at] != '\n' && text[at] != '\r') ++at;
      } else {
        ++at;
      }
    }
    if (at >= text.size() || !std::isdigit(text[at])) return std::nullopt;
    for (; at < text.size() && std::isdigit(text[at]); ++at) {
      values[v] = values[v] * 10 + (text[at] - '0');
      if (values[v] > (int64_t{1} << 32)) return std::nullopt;
    }
    if (at >= text.size()) return std::nullopt;  // the number may go on past what was read
  }
  ImageHeader header;
  header.format = "pnm";
  header.width = values[0];
  header.height = values[1];
  header.bit_depth = bitmap ? 1 : (values[2] < 256 ? 8 : 16);
  header.channels = kind == '3' || kind == '6' ? 3 : 1;
  return header;
}

std::optional<ImageHeader> BmpHeader(FileBytes& file) {
  std::array<uint8_t, 30> b{};
  if (!file.Read(0, 18, b.data())) return std::nullopt;
  const uint32_t info_size = Little32(b.data() + 14);
  ImageHeader header;
  header.format = "bmp";
  int bits = 0;
  if (info_size == 12) {
    if (!file.Read(0, 26, b.data())) return std::nullopt;
    header.width = Little16(b.data() + 18);
    header.height = Little16(b.data() + 20);
    bits = static_cast<int>(Little16(b.data() + 24));
  } else if (info_size >= 40) {
    if (!file.Read(0, 30, b.data())) return std::nullopt;
    header.width = static_cast<int32_t>(Little32(b.data() + 18));
    const int32_t height = static_cast<int32_t>(Little32(b.data() + 22));  // < 0: rows top-down
    header.height = height < 0 ? -int64_t{height} : height;
    bits = static_cast<int>(Little16(b.data() + 28));
  } else {
    return std::nullopt;
  }
  header.bit_depth = bits >= 24 ? 8 : bits;
  header.channels = bits >= 24 ? bits / 8 : 1;
  return header;
}

std::optional<ImageHeader> TiffHeader(FileBytes& file, bool little) {
  const auto u16 = [little](const uint8_t* p) { return little ? Little16(p) : Big16(p); };
  const auto u32 = [little](const uint8_t* p) { return little ? Little32(p) : Big32(p); };
  std::array<uint8_t, 12> b{};
  if (!file.Read(0, 8, b.data())) return std::nullopt;
  const uint64_t ifd = u32(b.data() + 4);
  if (!file.Read(ifd, 2, b.data())) return std::nullopt;
  const uint32_t entries = u16(b.data());
  ImageHeader header;
  header.format = "tiff";
  header.bit_depth = 1;  // the TIFF defaults
  header.channels = 1;
  for (uint32_t e = 0; e < entries; ++e) {
    if (!file.Read(ifd + 2 + 12 * uint64_t{e}, 12, b.data())) return std::nullopt;
    const uint32_t tag = u16(b.data()), type = u16(b.data() + 2), count = u32(b.data() + 4);
    if (type != 3 && type != 4) continue;  // SHORT, LONG
    const uint8_t* value = b.data() + 8;
    int64_t first = type == 3 ? u16(value) : u32(value);
    if (tag == 258 && count > 1) {  // BitsPerSample per sample: the first one, at the value offset
      std::array<uint8_t, 4> v{};
      if (count * (type == 3 ? 2u : 4u) <= 4) {
        std::memcpy(v.data(), value, 4);
      } else if (!file.Read(u32(value), 4, v.data())) {
        return std::nullopt;
      }
      first = type == 3 ? u16(v.data()) : u32(v.data());
    }
    if (tag == 256) header.width = first;
    if (tag == 257) header.height = first;
    if (tag == 258) header.bit_depth = static_cast<int>(first);
    if (tag == 277) header.channels = static_cast<int>(first);
  }
  if (header.width <= 0 || header.height <= 0) return std::nullopt;
  return header;
}

}  // namespace

std::optional<ImageHeader> ReadImageHeader(const std::filesystem::path& path) {
  FileBytes file(path);
  std::array<uint8_t, 8> head{};
  if (!file.Read(0, 4, head.data())) return std::nullopt;
  static constexpr uint8_t kPng[8] = {137, 80, 78, 71, 13, 10, 26, 10};
  if (file.Read(0, 8, head.data()) && std::memcmp(head.data(), kPng, 8) == 0) return PngHeader(file);
  if (head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF) return JpegHeader(file);
  if (head[0] == 'P' && head[1] >= '1' && head[1] <= '6' && std::isspace(head[2])) return PnmHeader(file, head[1]);
  if (head[0] == 'B' && head[1] == 'M') return BmpHeader(file);
  if (std::memcmp(head.data(), "II*\0", 4) == 0) return TiffHeader(file, /*little=*/true);
  if (std::memcmp(head.data(), "MM\0*", 4) == 0) return TiffHeader(file, /*little=*/false);
  return std::nullopt;
}

}  // namespace mcvo
