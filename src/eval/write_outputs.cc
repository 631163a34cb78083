// Kept apart from report.cc: this is the only eval file that needs the
// trajectory writers of mcvo_io.
#include "mcvo/eval/report.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/util/file.h"

namespace mcvo {

void WriteEvalOutputs(const std::filesystem::path& dir, const EvalResult& result) {
  CreateDirectories(dir);
  WriteFileAtomic(dir / "eval.json", EvalResultToJson(result));
  WriteFileAtomic(dir / "eval.md", EvalResultToMarkdown(result));
  WriteFileAtomic(dir / "ate_errors.csv", AteErrorsCsv(result));
  if (result.est_aligned.has_time) {
    WriteTrajectory(dir / "est_aligned.tum", result.est_aligned, TrajectoryFormat::kTum);
  } else {
    WriteTrajectory(dir / "est_aligned.kitti", result.est_aligned, TrajectoryFormat::kKitti);
  }
}

}  // namespace mcvo
