#include "mcvo/util/sha256.h"

#include <array>
#include <cstdio>
#include <fstream>

#include <openssl/evp.h>

#include "mcvo/util/error.h"

namespace mcvo {

struct Sha256::Impl {
  EVP_MD_CTX* ctx = nullptr;
  bool finished = false;
};

Sha256::Sha256() : impl_(std::make_unique<Impl>()) {
  impl_->ctx = EVP_MD_CTX_new();
  MCVO_CHECK(impl_->ctx != nullptr);
  MCVO_CHECK(EVP_DigestInit_ex(impl_->ctx, EVP_sha256(), nullptr) == 1);
}

Sha256::~Sha256() { EVP_MD_CTX_free(impl_->ctx); }

void Sha256::Update(std::string_view data) {
  MCVO_CHECK(!impl_->finished);
  MCVO_CHECK(EVP_DigestUpdate(impl_->ctx, data.data(), data.size()) == 1);
}

std::string Sha256::HexDigest() {
  MCVO_CHECK(!impl_->finished);
  impl_->finished = true;
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int size = 0;
  MCVO_CHECK(EVP_DigestFinal_ex(impl_->ctx, digest.data(), &size) == 1);
  std::string hex;
  static constexpr char kDigits[] = "0123456789abcdef";
  for (unsigned int i = 0; i < size; ++i) {
    hex += kDigits[digest[i] >> 4];
    hex += kDigits[digest[i] & 15];
  }
  return hex;
}

std::string Sha256Hex(std::string_view data) {
  Sha256 sha;
  sha.Update(data);
  return sha.HexDigest();
}

std::string Sha256File(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) MCVO_THROW_INPUT(path.string(), ": cannot open for reading");
  Sha256 sha;
  std::array<char, 1 << 16> buffer{};
  while (in) {
    in.read(buffer.data(), buffer.size());
    const std::streamsize got = in.gcount();
    if (got > 0) sha.Update(std::string_view(buffer.data(), static_cast<size_t>(got)));
  }
  if (in.bad()) MCVO_THROW_INPUT(path.string(), ": read error");
  return sha.HexDigest();
}

const std::string& ExecutableSha256() {
  static const std::string hash = [] {
    try {
      return Sha256File("/proc/self/exe");
    } catch (const std::exception&) {
      return std::string("unknown");
    }
  }();
  return hash;
}

}  // namespace mcvo
