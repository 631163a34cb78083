// The one output discipline of every mcvo command that writes (docs/run-outputs.md,
// "Output safety"): run, each run of a batch, synth, eval --out, track and vocab.
//
// A folder output (OutputFolder):
//  * never written in place: everything goes into a staging folder beside it,
//    "<out>.tmp-<pid>", moved into place only when complete;
//  * never where an input is: refused when --out is an input, contains one or
//    lies inside one (the dataset folder, the config, ...);
//  * never replacing what mcvo did not write: a folder mcvo wrote holds the
//    marker file ".mcvo-output"; a non-empty --out is replaced only with
//    --force and only when it holds the marker;
//  * never written by two processes at once: an exclusive lock (flock) on
//    "<parent>/.<out name>.lock" for the whole command; a second process
//    refuses at once, naming the lock and its holder;
//  * replaced atomically: the finished staging folder and the old output swap
//    places in one rename (renameat2 RENAME_EXCHANGE; two renames where the
//    file system cannot), then the old output is removed: --out is always
//    either the old output or the new one;
//  * cleaned up: the staging folder is removed on any error or on SIGINT /
//    SIGTERM (util/cancel.h); staging folders of processes that died (killed
//    with SIGKILL, a power cut) carry the marker ".mcvo-staging" and are
//    removed by the next command that takes the lock on the same --out.
//
// A file output (CheckOutputFile): written atomically (util/file.h), and
// refused when it is an input or lies inside an input folder.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace mcvo {

// The marker files: in every finished output folder, and in every staging folder.
inline constexpr const char* kOutputMarkerName = ".mcvo-output";
inline constexpr const char* kStagingMarkerName = ".mcvo-staging";

struct OutputFolderOptions {
  // Replace a non-empty output folder that mcvo wrote (holds the marker).
  bool force = false;
  // Files and folders the command reads: --out must not be, contain or lie
  // inside any of them. Empty paths are ignored.
  std::vector<std::filesystem::path> inputs;
  // What the folder holds, written into the marker: "run", "synth", "eval".
  std::string kind;
  // How the option is called in messages ("--out").
  std::string option = "--out";
};

class OutputFolder {
 public:
  // Checks the request, takes the lock, removes stale staging folders of the
  // same output and creates the staging folder. Throws InputError naming
  // `out` (and the input, the lock or the marker) when the output may not be
  // written.
  OutputFolder(const std::filesystem::path& out, OutputFolderOptions options);
  // Removes the staging folder unless Commit() ran; releases the lock.
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  // Where to write: the staging folder.
  const std::filesystem::path& staging() const { return staging_; }
  // The output folder, absolute and normalised.
  const std::filesystem::path& path() const { return out_; }

  // Writes the output marker into the staging folder and moves it into
  // place, replacing the old output atomically. Throws InputError naming the
  // output when the move fails (the old output, if any, is then untouched).
  void Commit();

 private:
  void Lock();
  void Unlock();
  void RemoveStaleStaging() const;

  std::filesystem::path out_;
  std::filesystem::path lock_path_;
  std::filesystem::path staging_;
  OutputFolderOptions options_;
  int lock_fd_ = -1;
  bool committed_ = false;
};

// Throws InputError when `out` (a file to be written) is one of `inputs`,
// or lies inside one of the input folders, or is an existing folder.
void CheckOutputFile(const std::filesystem::path& out, const std::vector<std::filesystem::path>& inputs,
                     const std::string& option = "--out");

// Why `out` may not be written over `input` ("is the input", "is inside
// the input folder", "contains the input"), or empty. Both paths are
// compared after resolving symbolic links (weakly_canonical).
std::string OverlapWithInput(const std::filesystem::path& out, const std::filesystem::path& input);

// The name of a sibling of `out` with `suffix` appended to out's name,
// shortened (with a hash of the whole name) when it would exceed the 255
// bytes a file name may have: "<name><suffix>" or "<prefix>~<hash><suffix>".
std::string SiblingName(const std::string& name, const std::string& suffix);

}  // namespace mcvo
