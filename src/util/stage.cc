#include "mcvo/util/stage.h"

#include <utility>

namespace mcvo {
namespace {

struct ThreadStages {
  std::vector<std::string> open;  // outermost first
  std::string failed;             // set by the innermost stage an exception left
};

ThreadStages& Stages() {
  thread_local ThreadStages stages;
  return stages;
}

std::string Join(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) {
    if (name.empty()) continue;
    if (!text.empty()) text += ": ";
    text += name;
  }
  return text;
}

}  // namespace

ScopedStage::ScopedStage(std::string name) : uncaught_at_entry_(std::uncaught_exceptions()) {
  ThreadStages& stages = Stages();
  stages.failed.clear();
  stages.open.push_back(std::move(name));
}

ScopedStage::~ScopedStage() {
  ThreadStages& stages = Stages();
  if (std::uncaught_exceptions() > uncaught_at_entry_) {
    // Left by an exception: the first (innermost) stage unwound says where.
    if (stages.failed.empty()) stages.failed = Join(stages.open);
  } else {
    stages.failed.clear();
  }
  if (!stages.open.empty()) stages.open.pop_back();
}

std::string CurrentStage() { return Join(Stages().open); }

std::vector<std::string> CurrentStageList() { return Stages().open; }

std::string FailedStage() {
  const ThreadStages& stages = Stages();
  return stages.failed.empty() ? Join(stages.open) : stages.failed;
}

StagedFailure CaptureFailure() { return {std::current_exception(), FailedStage()}; }

void RethrowFailure(const StagedFailure& failure) {
  Stages().failed = failure.stage;
  std::rethrow_exception(failure.error);
}

InheritedStages::InheritedStages(const std::vector<std::string>& outer) : saved_(std::move(Stages().open)) {
  Stages().open = outer;
}

InheritedStages::~InheritedStages() { Stages().open = std::move(saved_); }

std::string OutOfMemoryMessage(const std::string& command, const std::string& stage,
                               const std::string& what) {
  std::string line = "mcvo " + command + ": error: out of memory";
  if (!stage.empty()) line += " in " + stage;
  if (!what.empty()) line += " (" + what + ")";
  return line;
}

}  // namespace mcvo
