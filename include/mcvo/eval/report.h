// Text forms of an EvalResult: JSON (every key documented in docs/eval.md),
// a Markdown summary, the per-pose error CSV, and the files `mcvo eval
// --out DIR` writes. Same result -> byte-identical text (numbers are written
// by fixed, locale-independent routines; no maps with unordered iteration).
#pragma once

#include <filesystem>
#include <string>

#include "mcvo/eval/evaluate.h"

namespace mcvo {

// Version of the JSON layout; bumped when a key changes meaning or goes away.
inline constexpr int kEvalJsonVersion = 1;

// Pretty-printed JSON (2-space indent, trailing newline). Values that do not
// exist (stats of an empty set, scale without a Sim3) are null.
std::string EvalResultToJson(const EvalResult& result);

// Human summary: ATE and RPE tables, scale and start-end lines, notes.
std::string EvalResultToMarkdown(const EvalResult& result);

// One line per matched pose:
//   est_index,gt_index,t_s,frame_index,translation_error_m,rotation_error_deg
// t_s / frame_index are those of the estimated pose (empty when the
// estimate has none). Numbers round-trip (FormatDouble).
std::string AteErrorsCsv(const EvalResult& result);

// Creates `dir` and writes atomically: eval.json, eval.md, ate_errors.csv,
// and the aligned estimate as est_aligned.tum (or est_aligned.kitti, plain
// KITTI in pose order, when the estimate has no time stamps).
void WriteEvalOutputs(const std::filesystem::path& dir, const EvalResult& result);

}  // namespace mcvo
