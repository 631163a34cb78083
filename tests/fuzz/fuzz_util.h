// Helpers of the libFuzzer targets (tests/fuzz/*_fuzz.cc, docs/fuzzing.md).
//
// The contract every target checks: a reader given any bytes either returns
// or throws mcvo::InputError / mcvo::UsageError (include/mcvo/util/error.h).
// Those two are caught; anything else (another exception, an abort, an
// ASan/UBSan finding, a hang, a leak) escapes and libFuzzer reports a crash.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include "mcvo/util/error.h"

namespace mcvo::fuzz {

// Runs `body`; the documented errors of a reader are an expected outcome.
// Every message must name its source (the file): an empty message is a bug.
template <typename Body>
void ExpectOnlyInputErrors(const std::string& source, Body&& body) {
  try {
    body();
  } catch (const InputError& e) {
    if (std::string(e.what()).find(source) == std::string::npos) {
      std::fprintf(stderr, "InputError that does not name %s: %s\n", source.c_str(), e.what());
      std::abort();
    }
  } catch (const UsageError&) {
  }
}

// A scratch folder of this process, removed at exit:
// $TMPDIR/mcvo_fuzz_<name>_<pid>. Readers that only take a path read the
// input from a file in it (rewritten for every input).
inline const std::filesystem::path& ScratchDir(const std::string& name) {
  struct Folder {
    std::filesystem::path path;
    ~Folder() {
      std::error_code ec;
      if (!path.empty()) std::filesystem::remove_all(path, ec);
    }
  };
  static Folder folder;
  if (folder.path.empty()) {
    const char* tmp = std::getenv("TMPDIR");
    folder.path = std::filesystem::path(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") /
                  ("mcvo_fuzz_" + name + "_" + std::to_string(::getpid()));
    std::filesystem::create_directories(folder.path);
  }
  return folder.path;
}

// Writes the bytes to `path` (replacing it).
inline void WriteBytes(const std::filesystem::path& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) {
    std::fprintf(stderr, "cannot write %s\n", path.c_str());
    std::abort();
  }
}

}  // namespace mcvo::fuzz
