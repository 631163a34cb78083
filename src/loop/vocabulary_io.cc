// The vocabulary file (docs/loop-closure.md, "File format"). All numbers
// little-endian:
//
//   offset  size            field
//   0       8               magic "MCVOVOC1"
//   8       4   u32         format version (1)
//   12      4   u32         kind: 0 binary (CV_8U rows, Hamming), 1 float (CV_32F rows, L2)
//   16      4   u32         descriptor size: bytes (binary) or floats (float)
//   20      4   u32         branching (k)
//   24      4   u32         levels (L)
//   28      4   u32         nodes (N, the root included)
//   32      4   u32         words (W, the leaves)
//   36      4 N u32         child count of every node, breadth-first (node 0: the root)
//           (N - 1) R       centres of nodes 1 .. N-1, R bytes each (binary: the bytes;
//                           float: f32 values)
//           8 W f64         IDF of every word (word w: the w-th leaf in node order)
//           32              SHA-256 of all the bytes before it
//
// Load checks, in this order, and names the first problem: the magic, the
// version, the header's values, the file size they imply, the checksum, the
// tree (child counts that tile the breadth-first order, at most k children,
// depth at most L, W leaves), finite float centres, finite non-negative IDF.
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>

#include "mcvo/loop/vocabulary.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/sha256.h"
#include "vocabulary_internal.h"

namespace mcvo {
namespace {

constexpr char kMagic[8] = {'M', 'C', 'V', 'O', 'V', 'O', 'C', '1'};
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderBytes = 36;
constexpr size_t kChecksumBytes = 32;
// Sanity limits of the header's values (far above any useful vocabulary).
constexpr uint32_t kMaxDescriptorSize = 4096;
constexpr uint32_t kMaxBranching = 65535;
constexpr uint32_t kMaxLevels = 32;
constexpr uint32_t kMaxNodes = 1u << 28;

void PutU32(std::string* out, uint32_t value) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((value >> (8 * i)) & 0xFFu));
}

void PutU64(std::string* out, uint64_t value) {
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<char>((value >> (8 * i)) & 0xFFu));
}

uint32_t GetU32(const char* p) {
  uint32_t value = 0;
  for (int i = 0; i < 4; ++i) value |= static_cast<uint32_t>(static_cast<unsigned char>(p[i])) << (8 * i);
  return value;
}

uint64_t GetU64(const char* p) {
  uint64_t value = 0;
  for (int i = 0; i < 8; ++i) value |= static_cast<uint64_t>(static_cast<unsigned char>(p[i])) << (8 * i);
  return value;
}

// The SHA-256 digest as 32 bytes.
std::string RawSha256(std::string_view data) {
  const std::string hex = Sha256Hex(data);
  std::string raw(kChecksumBytes, '\0');
  for (size_t i = 0; i < kChecksumBytes; ++i) {
    raw[i] = static_cast<char>(std::stoi(hex.substr(2 * i, 2), nullptr, 16));
  }
  return raw;
}

}  // namespace

void Vocabulary::Save(const std::filesystem::path& path) const {
  MCVO_CHECK_MSG(!empty(), "Save of an empty vocabulary");
  const Impl& impl = *impl_;
  const int row_bytes = impl.RowBytes();
  const size_t nodes = impl.child_count.size();
  std::string out;
  out.reserve(kHeaderBytes + 4 * nodes + nodes * static_cast<size_t>(row_bytes) + 8 * impl.idf.size() +
              kChecksumBytes);
  out.append(kMagic, sizeof(kMagic));
  PutU32(&out, kVersion);
  PutU32(&out, impl.kind == DescriptorKind::kBinary ? 0u : 1u);
  PutU32(&out, static_cast<uint32_t>(impl.descriptor_size));
  PutU32(&out, static_cast<uint32_t>(impl.branching));
  PutU32(&out, static_cast<uint32_t>(impl.levels));
  PutU32(&out, static_cast<uint32_t>(nodes));
  PutU32(&out, static_cast<uint32_t>(impl.num_words));
  for (uint32_t count : impl.child_count) PutU32(&out, count);
  for (size_t node = 1; node < nodes; ++node) {
    const uint8_t* row = impl.centres.ptr<uint8_t>(static_cast<int>(node));
    if (impl.kind == DescriptorKind::kBinary) {
      out.append(reinterpret_cast<const char*>(row), static_cast<size_t>(row_bytes));
    } else {
      for (int d = 0; d < impl.descriptor_size; ++d) {
        uint32_t bits = 0;
        std::memcpy(&bits, row + 4 * static_cast<ptrdiff_t>(d), 4);
        PutU32(&out, bits);
      }
    }
  }
  for (double idf : impl.idf) {
    uint64_t bits = 0;
    std::memcpy(&bits, &idf, 8);
    PutU64(&out, bits);
  }
  out += RawSha256(out);
  WriteFileAtomic(path, out);
}

Vocabulary Vocabulary::Load(const std::filesystem::path& path) {
  const std::string data = ReadFileToString(path);
  const std::string name = path.string();
  const auto fail = [&name](const auto&... what) -> void { MCVO_THROW_INPUT(name, ": ", what...); };

  if (data.size() < sizeof(kMagic) || std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0) {
    fail("not an mcvo vocabulary (the file does not start with \"MCVOVOC1\")");
  }
  if (data.size() < kHeaderBytes) fail("truncated: ", data.size(), " bytes, shorter than the header");
  const char* p = data.data();
  const uint32_t version = GetU32(p + 8);
  if (version != kVersion)
    fail("unsupported vocabulary format version ", version, " (this mcvo reads version ", kVersion, ")");
  const uint32_t kind = GetU32(p + 12);
  const uint32_t descriptor_size = GetU32(p + 16);
  const uint32_t branching = GetU32(p + 20);
  const uint32_t levels = GetU32(p + 24);
  const uint32_t nodes = GetU32(p + 28);
  const uint32_t words = GetU32(p + 32);
  if (kind > 1) fail("unknown descriptor kind ", kind, " (0: binary, 1: float)");
  if (descriptor_size < 1 || descriptor_size > kMaxDescriptorSize) {
    fail("descriptor size ", descriptor_size, " out of range [1, ", kMaxDescriptorSize, "]");
  }
  if (branching < 2 || branching > kMaxBranching)
    fail("branching ", branching, " out of range [2, ", kMaxBranching, "]");
  if (levels < 1 || levels > kMaxLevels) fail("levels ", levels, " out of range [1, ", kMaxLevels, "]");
  if (nodes < 1 || nodes > kMaxNodes) fail("node count ", nodes, " out of range [1, ", kMaxNodes, "]");
  if (words < 1 || words > nodes) fail("word count ", words, " out of range [1, ", nodes, " nodes]");
  const uint64_t row_bytes = kind == 0 ? descriptor_size : 4ull * descriptor_size;
  const uint64_t expected =
      kHeaderBytes + 4ull * nodes + (nodes - 1ull) * row_bytes + 8ull * words + kChecksumBytes;
  if (data.size() < expected) fail("truncated: ", data.size(), " bytes, the header implies ", expected);
  if (data.size() > expected)
    fail(data.size() - expected, " unexpected bytes after the end (the header implies ", expected, " bytes)");
  const size_t body = data.size() - kChecksumBytes;
  if (RawSha256(std::string_view(data.data(), body)) !=
      std::string_view(data.data() + body, kChecksumBytes)) {
    fail("checksum mismatch: the file is corrupt");
  }

  Vocabulary vocabulary;
  Impl& impl = *vocabulary.impl_;
  impl.kind = kind == 0 ? DescriptorKind::kBinary : DescriptorKind::kFloat;
  impl.descriptor_size = static_cast<int>(descriptor_size);
  impl.branching = static_cast<int>(branching);
  impl.levels = static_cast<int>(levels);
  impl.child_count.resize(nodes);
  const char* q = p + kHeaderBytes;
  // The tree: children tile the breadth-first order after their parent.
  std::vector<uint32_t> depth(nodes, 0);
  uint64_t next = 1;
  uint32_t leaves = 0;
  for (uint32_t i = 0; i < nodes; ++i, q += 4) {
    const uint32_t count = GetU32(q);
    impl.child_count[i] = count;
    if (count == 0) {
      ++leaves;
      continue;
    }
    if (count > branching) fail("node ", i, " has ", count, " children, more than the branching ", branching);
    if (next <= i) fail("node ", i, " is not reachable from the root (bad child counts)");
    if (next + count > nodes) fail("the children of node ", i, " run past the ", nodes, " nodes");
    if (depth[i] + 1 > levels) fail("node ", i, " has children below the ", levels, " levels");
    for (uint64_t c = next; c < next + count; ++c) depth[c] = depth[i] + 1;
    next += count;
  }
  if (next != nodes) fail("the child counts account for ", next, " nodes, the header says ", nodes);
  if (leaves != words) fail("the tree has ", leaves, " leaves, the header says ", words, " words");

  impl.centres = cv::Mat(static_cast<int>(nodes), static_cast<int>(descriptor_size),
                         kind == 0 ? CV_8UC1 : CV_32FC1, cv::Scalar(0));
  for (uint32_t node = 1; node < nodes; ++node) {
    uint8_t* row = impl.centres.ptr<uint8_t>(static_cast<int>(node));
    if (kind == 0) {
      std::memcpy(row, q, row_bytes);
      q += row_bytes;
      continue;
    }
    float* values = reinterpret_cast<float*>(row);
    for (uint32_t d = 0; d < descriptor_size; ++d, q += 4) {
      const uint32_t bits = GetU32(q);
      std::memcpy(&values[d], &bits, 4);
      if (!std::isfinite(values[d])) fail("centre of node ", node, " has a non-finite value");
    }
  }
  impl.idf.resize(words);
  for (uint32_t w = 0; w < words; ++w, q += 8) {
    const uint64_t bits = GetU64(q);
    double idf = 0.0;
    std::memcpy(&idf, &bits, 8);
    if (!std::isfinite(idf) || idf < 0.0)
      fail("IDF of word ", w, " is ", idf, ", expected a finite value >= 0");
    impl.idf[w] = idf;
  }
  MCVO_CHECK(q == p + body);
  impl.Finalize();
  return vocabulary;
}

}  // namespace mcvo
