// Where the program is: a named stage per long step, so that an error with
// no context of its own (std::bad_alloc, an OpenCV out-of-memory) can say
// where it happened: "out of memory in run --out runs/a: frontend: frame 12".
//
//   void Track(int frame) {
//     const ScopedStage stage(StrCat("frontend: frame ", frame));
//     ...                          // CurrentStage() == "<outer>: frontend: frame 12"
//   }
//
// Stages nest per thread; CurrentStage() joins the open ones, outermost
// first, with ": ". A stage left by an exception records itself (the
// innermost one, with its outer stages) as this thread's FailedStage(), so a
// catch block above every stage can still name it. Work handed to another
// thread keeps the stages of the thread that handed it out (ParallelFor:
// InheritedStages), and an exception carried back to it carries its stage
// along (CaptureFailure / RethrowFailure), so the main thread names the
// stage of the worker where it failed.
//
// Stage names are built per step (per frame, per camera), never per pixel.
#pragma once

#include <exception>
#include <string>
#include <vector>

namespace mcvo {

class ScopedStage {
 public:
  explicit ScopedStage(std::string name);
  ~ScopedStage();
  ScopedStage(const ScopedStage&) = delete;
  ScopedStage& operator=(const ScopedStage&) = delete;

 private:
  int uncaught_at_entry_;
};

// The open stages of this thread, outermost first, joined by ": "; "" when none.
std::string CurrentStage();

// The stage the last exception on this thread left (the innermost), else
// CurrentStage(). Entering or normally leaving a stage forgets it.
std::string FailedStage();

// An exception caught on one thread, to be rethrown on another, with the
// stage where it happened.
struct StagedFailure {
  std::exception_ptr error;
  std::string stage;
  explicit operator bool() const { return static_cast<bool>(error); }
};

// Call inside a catch block.
StagedFailure CaptureFailure();
// Rethrows failure.error on this thread, as if it had left failure.stage here.
[[noreturn]] void RethrowFailure(const StagedFailure& failure);

// Gives the thread it is made on the stages of another thread (as
// CurrentStageList() returned them there) as its outer stages, for its lifetime.
class InheritedStages {
 public:
  explicit InheritedStages(const std::vector<std::string>& outer);
  ~InheritedStages();
  InheritedStages(const InheritedStages&) = delete;
  InheritedStages& operator=(const InheritedStages&) = delete;

 private:
  std::vector<std::string> saved_;
};
std::vector<std::string> CurrentStageList();

// "mcvo <command>: error: out of memory in <stage> (<what>)", or without
// " in <stage>" when stage is empty: what tools/ prints for std::bad_alloc
// and its kin.
std::string OutOfMemoryMessage(const std::string& command, const std::string& stage, const std::string& what);

}  // namespace mcvo
