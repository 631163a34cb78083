#include "mcvo/util/sha256.h"

#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "mcvo/util/error.h"

namespace mcvo {
namespace {

// FIPS 180-2 test vectors.
TEST(Sha256Test, KnownVectors) {
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

TEST(Sha256Test, IncrementalEqualsOneShotAndFilesHashTheirBytes) {
  std::string big(200000, '\0');
  for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>((i * 131) & 255);
  Sha256 sha;
  sha.Update(big.substr(0, 70000));
  sha.Update(big.substr(70000));
  const std::string digest = sha.HexDigest();
  EXPECT_EQ(digest, Sha256Hex(big));
  const std::string path = ::testing::TempDir() + "sha256_test_" + std::to_string(::getpid()) + ".bin";
  {
    std::ofstream out(path, std::ios::binary);
    out << big;
  }
  EXPECT_EQ(Sha256File(path), digest);
  std::remove(path.c_str());
  EXPECT_THROW(Sha256File(path), InputError);
}

}  // namespace
}  // namespace mcvo
