// SHA-256 (OpenSSL's libcrypto) as lowercase hex, as `sha256sum` prints it:
// run.json records the hashes of a run's inputs and outputs.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace mcvo {

class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void Update(std::string_view data);
  // Hex digest; the object cannot be updated afterwards.
  std::string HexDigest();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

std::string Sha256Hex(std::string_view data);
// Hash of a file's bytes; throws InputError naming the file when it cannot be read.
std::string Sha256File(const std::filesystem::path& path);
// SHA-256 of this process's executable (/proc/self/exe), computed once: what
// identifies the build that made an output (run.json "build"); "unknown"
// when it cannot be read.
const std::string& ExecutableSha256();

}  // namespace mcvo
