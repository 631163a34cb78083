// A temporary folder per test process: ctest runs every TEST as its own
// process, in parallel, so each process gets "<TempDir>/mcvo_<suite>_<pid>",
// created on first use and removed when the process ends.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace mcvo::testing {

inline std::filesystem::path TestTempDir(const std::string& suite) {
  struct Folder {
    std::filesystem::path path;
    ~Folder() {
      std::error_code ec;
      if (!path.empty()) std::filesystem::remove_all(path, ec);
    }
  };
  static Folder folder;
  if (folder.path.empty()) {
    folder.path =
        std::filesystem::path(::testing::TempDir()) / ("mcvo_" + suite + "_" + std::to_string(::getpid()));
  }
  std::filesystem::create_directories(folder.path);
  return folder.path;
}

}  // namespace mcvo::testing
