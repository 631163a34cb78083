// File helpers. Every output file of mcvo is written through AtomicFileWriter:
// the content goes to "<path>.tmp.<pid>" and is renamed onto <path> only when
// complete, so a crash or an error never leaves a half-written file that
// looks complete.
#pragma once

#include <filesystem>
#include <fstream>
#include <memory>
#include <ostream>
#include <string>
#include <system_error>
#include <utility>

namespace mcvo {

class AtomicFileWriter {
 public:
  // Opens the temporary file (never through a symbolic link); throws
  // InputError naming `path` and the reason when it cannot.
  explicit AtomicFileWriter(std::filesystem::path path);
  // Removes the temporary file if Commit() was not called.
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  std::ostream& stream() { return out_; }
  // Flushes, closes and renames onto the final path. Throws InputError
  // "<path>: write failed: <reason>" when a write or the close failed, the
  // reason from the system ("No space left on device", ...).
  void Commit();

  // The message of a failed write of `path` with the errno it failed with
  // (0: reason unknown).
  static std::string WriteFailedMessage(const std::filesystem::path& path, int error);

 private:
  // Buffered writes to a file descriptor that keep the errno of the first
  // failed write() or close() (std::ofstream loses it).
  class FileBuffer;

  std::filesystem::path path_;
  std::filesystem::path tmp_path_;
  std::unique_ptr<FileBuffer> buffer_;
  std::ostream out_{nullptr};
  bool committed_ = false;
};

// Writes `content` to `path` atomically.
void WriteFileAtomic(const std::filesystem::path& path, const std::string& content);

// Reads a whole file; throws InputError "<path>: cannot open" when it cannot.
std::string ReadFileToString(const std::filesystem::path& path);

// Why `path` cannot be read as a file (WhyNotAFile) or listed as a folder
// (WhyNotAFolder), for an error message: "does not exist", "is a folder,
// not a file", "is a symbolic link loop", "is a dangling symbolic link",
// ...; empty when it can.
std::string WhyNotAFile(const std::filesystem::path& path);
std::string WhyNotAFolder(const std::filesystem::path& path);

// Creates `dir` (and parents); throws InputError naming it on failure.
void CreateDirectories(const std::filesystem::path& dir);

// A folder removed with everything in it when the object goes out of scope,
// unless Release() was called: the staging folder of outputs that are
// renamed into place only when complete.
class TemporaryFolder {
 public:
  explicit TemporaryFolder(std::filesystem::path path) : path_(std::move(path)) {}
  ~TemporaryFolder() {
    if (!path_.empty()) {
      std::error_code ec;
      std::filesystem::remove_all(path_, ec);
    }
  }
  TemporaryFolder(const TemporaryFolder&) = delete;
  TemporaryFolder& operator=(const TemporaryFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }
  void Release() { path_.clear(); }

 private:
  std::filesystem::path path_;
};

}  // namespace mcvo
