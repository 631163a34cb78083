// Rendered test fixtures, once per build: `mcvo synth ARGS` into
// MCVO_TEST_FIXTURE_DIR (build/test_fixtures), keyed by the arguments and by
// the mcvo binary (size and modification time: a rebuilt renderer renders
// again). ctest runs every test as its own process, often two at once, so
// the cache is shared between processes: an flock(2) per fixture, the
// render written to a temporary folder and renamed into place, and the
// arguments stored beside it and compared (a hash collision or a half-done
// render is rendered again). Tests read a fixture and never write into it.
#pragma once

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tools/run_mcvo.h"

namespace mcvo::test {

// What identifies the binary that renders: its size and mtime in ns.
inline std::string BinaryIdentity() {
  struct stat st {};
  if (::stat(MCVO_BINARY, &st) != 0) return "missing";
  return std::to_string(st.st_size) + ":" + std::to_string(st.st_mtim.tv_sec) + "." +
         std::to_string(st.st_mtim.tv_nsec);
}

// FNV-1a, 64 bits: a folder name, not a security hash (the stored
// arguments are compared too).
inline std::string Fnv1aHex(const std::string& text) {
  uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  char buffer[17];
  std::snprintf(buffer, sizeof(buffer), "%016llx", static_cast<unsigned long long>(h));
  return buffer;
}

inline std::string ReadWhole(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The folder of `mcvo synth <synth_args> --out <folder>` (synth_args without
// --out), rendering it unless this build already did. On a render failure:
// the empty path, with mcvo's output in *error.
inline std::filesystem::path CachedSynth(const std::string& synth_args, std::string* error = nullptr) {
  namespace fs = std::filesystem;
  const fs::path root = MCVO_TEST_FIXTURE_DIR;
  fs::create_directories(root);
  const std::string key = synth_args + "\n" + BinaryIdentity();
  const std::string name = Fnv1aHex(key);
  const fs::path dir = root / name;
  const fs::path stamp = root / (name + ".key");  // written last: the render is complete
  const int lock = ::open((root / (name + ".lock")).c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock < 0 || ::flock(lock, LOCK_EX) != 0) {
    if (error != nullptr) *error = "cannot lock the fixture cache in " + root.string();
    if (lock >= 0) ::close(lock);
    return {};
  }
  fs::path result;
  if (fs::is_directory(dir) && fs::is_regular_file(stamp) && ReadWhole(stamp) == key) {
    result = dir;
  } else {
    const fs::path tmp = root / (name + ".tmp");
    std::error_code ec;
    fs::remove_all(tmp, ec);
    fs::remove_all(dir, ec);
    fs::remove(stamp, ec);
    const Result r = RunMcvo("synth " + synth_args + " --out " + Quote(tmp.string()));
    if (r.exit_code == 0) {
      fs::rename(tmp, dir);
      std::ofstream(stamp, std::ios::binary) << key;
      result = dir;
    } else if (error != nullptr) {
      *error = r.output;
    }
  }
  ::flock(lock, LOCK_UN);
  ::close(lock);
  return result;
}

// The 12-frame one-camera render (352 x 94 px) that the bad-input,
// output-safety, hostile-name and config-bound CLI tests start from:
// rendered once per build, shared through the cache.
inline const std::filesystem::path& SmallMonoRender() {
  static const std::filesystem::path dir = [] {
    std::string error;
    const std::filesystem::path seq =
        CachedSynth("--preset mono --frames 12 --image-scale 0.25 --samples 1 --seed 3", &error);
    EXPECT_FALSE(seq.empty()) << error;
    return seq;
  }();
  return dir;
}

}  // namespace mcvo::test
