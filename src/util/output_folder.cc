#include "mcvo/util/output_folder.h"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <system_error>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/sha256.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

constexpr size_t kMaxFileName = 255;

fs::path Normalised(const fs::path& path) {
  std::error_code ec;
  fs::path absolute = fs::absolute(path, ec);
  if (ec) absolute = path;
  absolute = absolute.lexically_normal();
  // "out/" normalises to "out/" with an empty filename: drop the separator.
  if (absolute.filename().empty() && absolute.has_parent_path()) absolute = absolute.parent_path();
  return absolute;
}

fs::path Resolved(const fs::path& path) {
  std::error_code ec;
  const fs::path resolved = fs::weakly_canonical(Normalised(path), ec);
  return ec ? Normalised(path) : resolved;
}

// True when `inner` is `outer` or lies below it (both resolved).
bool IsWithin(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (o->empty()) continue;  // a trailing separator
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

bool IsRegularFile(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(fs::symlink_status(path, ec));
}

bool HasOutputMarker(const fs::path& dir) { return IsRegularFile(dir / kOutputMarkerName); }

bool IsEmptyFolder(const fs::path& dir) {
  std::error_code ec;
  return fs::is_empty(dir, ec) && !ec;
}

bool ProcessAlive(long pid) {
  if (pid <= 0) return false;
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

// The pid of a sibling named SiblingName(name, tag + "<pid>"), or -1.
long SiblingPid(const std::string& entry, const std::string& name, const std::string& tag) {
  const size_t at = entry.rfind(tag);
  if (at == std::string::npos || at + tag.size() >= entry.size()) return -1;
  const std::string digits = entry.substr(at + tag.size());
  if (digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(c); }))
    return -1;
  if (SiblingName(name, tag + digits) != entry) return -1;
  return std::stol(digits);
}

// Why the existing `out` may not be replaced, or empty when it may.
std::string WhyNotReplaceable(const fs::path& out, bool force, const std::string& option) {
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(out, ec);
  if (ec || !fs::exists(status)) return {};
  if (fs::is_symlink(status)) {
    return "is a symbolic link; give the folder itself (mcvo replaces the folder, which would replace the "
           "link)";
  }
  if (!fs::is_directory(status)) return "exists and is not a folder";
  if (IsEmptyFolder(out)) return {};
  if (!force) return "folder exists and is not empty (use --force to replace an earlier mcvo output)";
  if (!HasOutputMarker(out)) {
    return StrCat("is not empty and holds no ", kOutputMarkerName,
                  " marker: mcvo replaces only folders it wrote, even with --force (remove it yourself or "
                  "choose another ",
                  option, ")");
  }
  return {};
}

std::string ErrnoText() { return std::strerror(errno); }

}  // namespace

std::string SiblingName(const std::string& name, const std::string& suffix) {
  if (name.size() + suffix.size() <= kMaxFileName) return name + suffix;
  // 1 for '~', 16 hex digits of the hash.
  const size_t keep = kMaxFileName - suffix.size() - 17;
  size_t cut = std::min(keep, name.size());
  // Cut on a UTF-8 character boundary.
  while (cut > 0 && (static_cast<unsigned char>(name[cut]) & 0xC0) == 0x80) --cut;
  return name.substr(0, cut) + "~" + Sha256Hex(name).substr(0, 16) + suffix;
}

std::string OverlapWithInput(const fs::path& out, const fs::path& input) {
  if (input.empty()) return {};
  const fs::path a = Resolved(out);
  const fs::path b = Resolved(input);
  if (a == b) return "is the input " + input.string();
  if (IsWithin(b, a)) return "contains the input " + input.string();
  std::error_code ec;
  if (IsWithin(a, b) && fs::is_directory(b, ec)) return "is inside the input folder " + input.string();
  return {};
}

void CheckOutputFile(const fs::path& out, const std::vector<fs::path>& inputs, const std::string& option) {
  std::error_code ec;
  if (fs::is_directory(out, ec))
    MCVO_THROW_INPUT(out.string(), ": ", option, ": is a folder, expected a file");
  for (const fs::path& input : inputs) {
    if (const std::string overlap = OverlapWithInput(out, input); !overlap.empty()) {
      MCVO_THROW_INPUT(out.string(), ": ", option, ": ", overlap, "; mcvo never writes over its inputs");
    }
  }
}

OutputFolder::OutputFolder(const fs::path& out, OutputFolderOptions options)
    : out_(Normalised(out)), options_(std::move(options)) {
  const std::string& option = options_.option;
  if (out.empty() || out_.filename().empty() || out_.filename() == "." || out_.filename() == "..")
    MCVO_THROW_INPUT(out.string(), ": ", option, ": not a folder name that can be written");
  for (const fs::path& input : options_.inputs) {
    if (const std::string overlap = OverlapWithInput(out_, input); !overlap.empty()) {
      MCVO_THROW_INPUT(out.string(), ": ", option, ": ", overlap,
                       "; mcvo never writes over or inside its inputs (choose an output folder elsewhere)");
    }
  }
  if (const std::string why = WhyNotReplaceable(out_, options_.force, option); !why.empty())
    MCVO_THROW_INPUT(out.string(), ": ", why);
  try {
    CreateDirectories(out_.parent_path());
  } catch (const InputError& e) {
    MCVO_THROW_INPUT(out.string(), ": cannot create the output folder's parent (", e.what(), ")");
  }
  const std::string name = out_.filename().string();
  lock_path_ = out_.parent_path() / SiblingName("." + name, ".lock");
  Lock();
  try {
    // Under the lock, nothing else of ours writes this output: the checks again
    // (another process may have replaced it while we waited for nothing).
    if (const std::string why = WhyNotReplaceable(out_, options_.force, option); !why.empty())
      MCVO_THROW_INPUT(out.string(), ": ", why);
    RemoveStaleStaging();
    staging_ = out_.parent_path() / SiblingName(name, ".tmp-" + std::to_string(::getpid()));
    std::error_code ec;
    if (fs::exists(fs::symlink_status(staging_, ec))) {
      MCVO_THROW_INPUT(staging_.string(),
                       ": exists and is not a staging folder of mcvo; remove it or choose "
                       "another ",
                       option);
    }
    if (!fs::create_directory(staging_, ec) || ec) {
      MCVO_THROW_INPUT(out.string(), ": cannot create the staging folder ", staging_.string(), ": ",
                       ec ? ec.message() : std::string("it exists"));
    }
    WriteFileAtomic(staging_ / kStagingMarkerName, name + "\n");
  } catch (...) {
    if (!staging_.empty()) {
      std::error_code ec;
      if (IsRegularFile(staging_ / kStagingMarkerName)) fs::remove_all(staging_, ec);
      staging_.clear();
    }
    Unlock();
    throw;
  }
}

OutputFolder::~OutputFolder() {
  if (!committed_ && !staging_.empty()) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
  }
  Unlock();
}

void OutputFolder::Lock() {
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      MCVO_THROW_INPUT(out_.string(), ": cannot create the output folder: cannot create its lock file ",
                       lock_path_.string(), ": ", ErrnoText());
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int error = errno;
      char buffer[32] = {0};
      const ssize_t n = ::pread(fd, buffer, sizeof(buffer) - 1, 0);
      ::close(fd);
      std::string holder = n > 0 ? std::string(buffer, static_cast<size_t>(n)) : std::string();
      while (!holder.empty() && (holder.back() == '\n' || holder.back() == ' ')) holder.pop_back();
      if (error == EWOULDBLOCK) {
        MCVO_THROW_INPUT(out_.string(), ": is being written by another mcvo",
                         holder.empty() ? std::string() : " (process " + holder + ")", "; it holds the lock ",
                         lock_path_.string());
      }
      MCVO_THROW_INPUT(out_.string(), ": cannot lock ", lock_path_.string(), ": ", std::strerror(error));
    }
    // The lock file may have been removed (and another created) by the
    // holder we waited for: the lock counts only on the file at the path.
    struct stat held {};
    struct stat at_path {};
    if (::fstat(fd, &held) == 0 && ::stat(lock_path_.c_str(), &at_path) == 0 &&
        held.st_dev == at_path.st_dev && held.st_ino == at_path.st_ino) {
      const std::string pid = std::to_string(::getpid()) + "\n";
      if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) < 0) {
        // The pid is for messages only; the lock holds without it.
      }
      lock_fd_ = fd;
      return;
    }
    ::close(fd);
  }
  MCVO_THROW_INPUT(out_.string(), ": cannot take the lock ", lock_path_.string(), " (it keeps changing)");
}

void OutputFolder::Unlock() {
  if (lock_fd_ < 0) return;
  // Removed while still held, so that a process that opened it meanwhile
  // sees a different file at the path and tries again (Lock).
  ::unlink(lock_path_.c_str());
  ::close(lock_fd_);
  lock_fd_ = -1;
}

void OutputFolder::RemoveStaleStaging() const {
  const std::string name = out_.filename().string();
  std::error_code ec;
  const fs::path parent = out_.parent_path();
  // An interrupted replace without RENAME_EXCHANGE (see Commit) left the
  // old output at "<name>.old-<pid>" and none at <name>: put it back.
  std::vector<fs::path> stale;
  for (fs::directory_iterator it(parent, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string entry = it->path().filename().string();
    if (entry.compare(0, std::min<size_t>(name.size(), 100), name, 0, std::min<size_t>(name.size(), 100)) !=
        0)
      continue;
    const long staging_pid = SiblingPid(entry, name, ".tmp-");
    const long old_pid = SiblingPid(entry, name, ".old-");
    if (staging_pid < 0 && old_pid < 0) continue;
    std::error_code status_ec;
    if (!fs::is_directory(fs::symlink_status(it->path(), status_ec))) continue;
    const bool ours = IsRegularFile(it->path() / kStagingMarkerName) || HasOutputMarker(it->path());
    if (!ours) {
      if (!ProcessAlive(staging_pid >= 0 ? staging_pid : old_pid)) {
        MCVO_LOG(
            kWarning, "output: ", it->path().string(),
            " looks like the staging folder of a process that ended, but holds no mcvo marker (an earlier "
            "mcvo version wrote it?): not removed, remove it yourself");
      }
      continue;
    }
    if (old_pid >= 0 && !fs::exists(fs::symlink_status(out_, status_ec))) {
      std::error_code rename_ec;
      fs::rename(it->path(), out_, rename_ec);
      if (!rename_ec) {
        MCVO_LOG(kWarning, "output: ", out_.string(), ": restored the previous output from ", entry,
                 " (a replace was interrupted)");
        continue;
      }
    }
    stale.push_back(it->path());
  }
  for (const fs::path& path : stale) {
    std::error_code remove_ec;
    fs::remove_all(path, remove_ec);
    if (remove_ec) {
      MCVO_LOG(kWarning, "output: cannot remove the stale staging folder ", path.string(), ": ",
               remove_ec.message());
    } else {
      MCVO_LOG(kInfo, "output: removed the stale staging folder ", path.string(), " (its process ended)");
    }
  }
}

void OutputFolder::Commit() {
  MCVO_CHECK(!committed_ && !staging_.empty());
  std::error_code ec;
  // Files that appeared in --out while the command ran (not written by an
  // mcvo: those are locked out) are never replaced.
  if (const std::string why = WhyNotReplaceable(out_, options_.force, options_.option); !why.empty()) {
    MCVO_THROW_INPUT(out_.string(), ": ", why, " (it changed while mcvo ran; nothing was written)");
  }
  WriteFileAtomic(staging_ / kOutputMarkerName,
                  "{\"written_by\": \"mcvo\", \"kind\": \"" + options_.kind + "\"}\n");
  fs::remove(staging_ / kStagingMarkerName, ec);
  const bool exists = fs::exists(fs::symlink_status(out_, ec));
  if (!exists) {
    fs::rename(staging_, out_, ec);
    if (ec) MCVO_THROW_INPUT(out_.string(), ": cannot move the finished output into place: ", ec.message());
    committed_ = true;
    return;
  }
  // Swap the new output and the old one in one step; the old one, now at
  // the staging path, is removed after.
  if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, out_.c_str(), RENAME_EXCHANGE) == 0) {
    committed_ = true;
    fs::remove_all(staging_, ec);
    if (ec)
      MCVO_LOG(kWarning, "output: cannot remove the replaced output ", staging_.string(), ": ", ec.message());
    return;
  }
  if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP) {
    MCVO_THROW_INPUT(out_.string(), ": cannot move the finished output into place: ", ErrnoText());
  }
  // A file system without RENAME_EXCHANGE (NFS): the old output aside, the
  // new one in, the old one removed. An interruption between the two
  // renames is repaired by the next command on this output (RemoveStaleStaging).
  const fs::path old =
      out_.parent_path() / SiblingName(out_.filename().string(), ".old-" + std::to_string(::getpid()));
  fs::rename(out_, old, ec);
  if (ec) MCVO_THROW_INPUT(out_.string(), ": cannot move the old output aside: ", ec.message());
  fs::rename(staging_, out_, ec);
  if (ec) {
    std::error_code back;
    fs::rename(old, out_, back);
    MCVO_THROW_INPUT(out_.string(), ": cannot move the finished output into place: ", ec.message());
  }
  committed_ = true;
  fs::remove_all(old, ec);
}

}  // namespace mcvo
