#include "mcvo/util/file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <sstream>
#include <streambuf>
#include <system_error>

#include "mcvo/util/error.h"

namespace mcvo {

class AtomicFileWriter::FileBuffer : public std::streambuf {
 public:
  explicit FileBuffer(int fd) : fd_(fd) { setp(buffer_, buffer_ + sizeof(buffer_)); }
  ~FileBuffer() override { Close(); }
  FileBuffer(const FileBuffer&) = delete;
  FileBuffer& operator=(const FileBuffer&) = delete;

  // errno of the first failed write or close; 0 when none failed.
  int error() const { return error_; }
  // Writes what is buffered and closes; false when anything failed.
  bool Close() {
    if (fd_ < 0) return error_ == 0;
    Drain();
    if (::close(fd_) != 0 && error_ == 0) error_ = errno;
    fd_ = -1;
    return error_ == 0;
  }

 protected:
  int_type overflow(int_type ch) override {
    if (!Drain()) return traits_type::eof();
    if (!traits_type::eq_int_type(ch, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(ch);
      pbump(1);
    }
    return traits_type::not_eof(ch);
  }
  int sync() override { return Drain() ? 0 : -1; }

 private:
  // Writes the buffer out; after a failure nothing more is written.
  bool Drain() {
    const char* data = pbase();
    size_t left = static_cast<size_t>(pptr() - pbase());
    while (left > 0 && error_ == 0) {
      const ssize_t n = ::write(fd_, data, left);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        error_ = n < 0 ? errno : EIO;
        break;
      }
      data += n;
      left -= static_cast<size_t>(n);
    }
    setp(buffer_, buffer_ + sizeof(buffer_));
    return error_ == 0;
  }

  int fd_;
  int error_ = 0;
  char buffer_[1 << 16];
};

AtomicFileWriter::AtomicFileWriter(std::filesystem::path path) : path_(std::move(path)) {
  tmp_path_ = path_;
  tmp_path_ += ".tmp." + std::to_string(::getpid());
  // O_NOFOLLOW: a symbolic link planted at the temporary name must not send
  // the output somewhere else.
  const int fd = ::open(tmp_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0666);
  if (fd < 0) {
    const int error = errno;
    MCVO_THROW_INPUT(path_.string(), ": cannot open for writing: ", std::generic_category().message(error));
  }
  buffer_ = std::make_unique<FileBuffer>(fd);
  out_.rdbuf(buffer_.get());
  // Fixed formatting regardless of the global locale.
  out_.imbue(std::locale::classic());
}

AtomicFileWriter::~AtomicFileWriter() {
  if (!committed_) {
    if (buffer_ != nullptr) buffer_->Close();
    std::error_code ec;
    std::filesystem::remove(tmp_path_, ec);
  }
}

std::string AtomicFileWriter::WriteFailedMessage(const std::filesystem::path& path, int error) {
  return path.string() + ": write failed" + (error != 0 ? ": " + std::generic_category().message(error) : "");
}

void AtomicFileWriter::Commit() {
  MCVO_CHECK(!committed_);
  out_.flush();
  const bool ok = static_cast<bool>(out_);
  const bool closed = buffer_->Close();
  if (!ok || !closed) throw InputError(WriteFailedMessage(path_, buffer_->error()));
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
