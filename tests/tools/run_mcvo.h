// Runs the built `mcvo` executable as a user would, for the CLI tests.
#pragma once

#include <sys/wait.h>

#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include <gtest/gtest.h>

namespace mcvo::test {

struct Result {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Single-quotes text for /bin/sh.
inline std::string Quote(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Runs a /bin/sh command line and captures its output (stdout and stderr
// together) and exit code (-1 when it did not exit normally).
inline Result RunShell(const std::string& command) {
  Result result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer{};
  size_t n = 0;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

// Runs `mcvo <args>` (args already quoted where needed).
inline Result RunMcvo(const std::string& args) { return RunShell(Quote(MCVO_BINARY) + " " + args); }

// RunMcvo with a wall-clock limit: a command still running after `seconds`
// is killed and reported as exit code 124 (a hang is a failure, not a stall
// of the test suite).
inline Result RunMcvoWithin(int seconds, const std::string& args) {
  return RunShell("timeout --kill-after=5 " + std::to_string(seconds) + " " + Quote(MCVO_BINARY) + " " +
                  args);
}

// A scratch folder of this test process, `<TempDir>/<prefix>_<pid>`, emptied
// and created on the first call for each prefix (call it from one function
// per file, which keeps it in a static), and removed with everything in it
// when the process exits (ctest runs each TEST as its own process, so
// without that every run left one folder per test behind).
inline std::filesystem::path ProcessScratch(const std::string& prefix) {
  struct Folders {
    std::vector<std::filesystem::path> paths;
    ~Folders() {
      std::error_code ec;
      for (const std::filesystem::path& p : paths) std::filesystem::remove_all(p, ec);
    }
  };
  static Folders folders;
  const std::filesystem::path root =
      std::filesystem::path(::testing::TempDir()) / (prefix + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(root);
  std::filesystem::create_directories(root);
  folders.paths.push_back(root);
  return root;
}

// The error lines of a command's output: "mcvo run: error: ..." or "mcvo
// run: usage error: ..." (not "reprojection error" in an info line).
inline std::vector<std::string> ErrorLines(const std::string& output) {
  std::vector<std::string> lines;
  size_t start = 0;
  while (start < output.size()) {
    size_t end = output.find('\n', start);
    if (end == std::string::npos) end = output.size();
    const std::string line = output.substr(start, end - start);
    if (line.rfind("mcvo ", 0) == 0 && line.find(" error: ") != std::string::npos) lines.push_back(line);
    start = end + 1;
  }
  return lines;
}

}  // namespace mcvo::test
