#include "mcvo/util/file.h"

#include <unistd.h>

#include <sstream>
#include <system_error>

#include "mcvo/util/error.h"

namespace mcvo {

AtomicFileWriter::AtomicFileWriter(std::filesystem::path path) : path_(std::move(path)) {
  tmp_path_ = path_;
  tmp_path_ += ".tmp." + std::to_string(::getpid());
  out_.open(tmp_path_, std::ios::out | std::ios::binary | std::ios::trunc);
  if (!out_) MCVO_THROW_INPUT(path_.string(), ": cannot open for writing");
  // Fixed formatting regardless of the global locale.
  out_.imbue(std::locale::classic());
}

AtomicFileWriter::~AtomicFileWriter() {
  if (!committed_) {
    out_.close();
    std::error_code ec;
    std::filesystem::remove(tmp_path_, ec);
  }
}

void AtomicFileWriter::Commit() {
  MCVO_CHECK(!committed_);
  out_.flush();
  const bool ok = static_cast<bool>(out_);
  out_.close();
  if (!ok || out_.fail()) MCVO_THROW_INPUT(path_.string(), ": write failed");
  std::error_code ec;
  std::filesystem::rename(tmp_path_, path_, ec);
  if (ec) MCVO_THROW_INPUT(path_.string(), ": cannot rename temporary file: ", ec.message());
  committed_ = true;
}

void WriteFileAtomic(const std::filesystem::path& path, const std::string& content) {
  AtomicFileWriter writer(path);
  writer.stream() << content;
  writer.Commit();
}

std::string ReadFileToString(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    MCVO_THROW_INPUT(path.string(), ": is a directory, expected a file");
  std::ifstream in(path, std::ios::in | std::ios::binary);
  if (!in) MCVO_THROW_INPUT(path.string(), ": cannot open for reading");
  std::ostringstream content;
  content << in.rdbuf();
  if (in.bad()) MCVO_THROW_INPUT(path.string(), ": read failed");
  return content.str();
}

namespace {

// What is at `path` when it is not what was wanted; empty when it is.
std::string WhyNot(const std::filesystem::path& path, bool want_folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::error_code follow;
  const fs::file_status target = fs::status(path, follow);
  if (!follow && (want_folder ? fs::is_directory(target) : fs::is_regular_file(target))) return {};
  const fs::file_status link = fs::symlink_status(path, ec);
  if (ec || !fs::exists(link)) return "does not exist";
  if (fs::is_symlink(link)) {
    if (follow == std::errc::too_many_symbolic_link_levels) return "is a symbolic link loop";
    if (follow || !fs::exists(target)) return "is a dangling symbolic link";
  }
  if (fs::is_directory(target)) return "is a folder, not a file";
  if (fs::is_regular_file(target)) return "is a file, not a folder";
  return want_folder ? "is not a folder" : "is not a regular file";
}

}  // namespace

std::string WhyNotAFile(const std::filesystem::path& path) { return WhyNot(path, false); }
std::string WhyNotAFolder(const std::filesystem::path& path) { return WhyNot(path, true); }

void CreateDirectories(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) MCVO_THROW_INPUT(dir.string(), ": cannot create directory: ", ec.message());
}

}  // namespace mcvo
