// `mcvo regress`: compares two run folders, byte for byte or within
// tolerances (pipeline/regress.h; docs/batch-and-regress.md).
#include <iostream>
#include <string>

#include "command.h"
#include "mcvo/pipeline/regress.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::tools {
namespace {

// Exit code when the comparison worked and the folders differ.
constexpr int kExitDifferent = 4;

int RunRegress(int argc, const char* const* argv) {
  std::string baseline, candidate, tolerances_path, ignore;
  double translation_m = 0.0, rotation_deg = 0.0, absolute = 0.0, relative = 0.0;
  ArgParser args("mcvo regress",
                 "Compares two run folders of `mcvo run`: run.json and every output it lists (timing.csv\n"
                 "aside). Without tolerances every file must be byte-identical (JSON files value for\n"
                 "value, ignoring timing, version, command line and paths); with tolerances, trajectories\n"
                 "are compared pose by pose, CSV cells, JSON values and numbers in text numerically.");
  args.AddString("baseline", &baseline, "DIR", "the reference run folder", true);
  args.AddString("candidate", &candidate, "DIR", "the run folder to check", true);
  args.AddString("tolerances", &tolerances_path, "FILE",
                 "tolerance file (JSON; docs/batch-and-regress.md); the flags below override it");
  args.AddDouble("translation-m", &translation_m, "per-pose translation tolerance of trajectories, metres");
  args.AddDouble("rotation-deg", &rotation_deg, "per-pose rotation tolerance of trajectories, degrees");
  args.AddDouble("abs", &absolute, "absolute tolerance of numbers (CSV, JSON, text)");
  args.AddDouble("rel", &relative, "relative tolerance of numbers (CSV, JSON, text)");
  args.AddString("ignore", &ignore, "GLOB,...", "files not to compare (relative paths; * crosses '/')");
  args.AddEpilog(
      "Any tolerance (file or flag) switches from exact to tolerant comparison; tolerances not given\n"
      "are 0. Exit codes: 0 equal (within the tolerances), 4 different (or a file missing on one\n"
      "side), 2 usage, 3 bad input (not a run folder, bad tolerance file).\n"
      "example: mcvo regress --baseline runs/v1/k360 --candidate runs/v2/k360 --translation-m 0.001 \\\n"
      "           --rotation-deg 0.01 --rel 1e-6\n");
  if (!args.Parse(argc, argv)) return kExitOk;
  for (const auto& [name, value] : {std::pair<const char*, double>{"translation-m", translation_m},
                                    {"rotation-deg", rotation_deg},
                                    {"abs", absolute},
                                    {"rel", relative}}) {
    if (args.WasGiven(name) && !(value >= 0.0)) throw UsageError(StrCat("--", name, ": must be >= 0"));
  }

  RegressOptions options;
  if (!tolerances_path.empty()) ReadRegressTolerances(tolerances_path, &options);
  if (args.WasGiven("translation-m")) options.translation_m = translation_m;
  if (args.WasGiven("rotation-deg")) options.rotation_deg = rotation_deg;
  if (args.WasGiven("abs")) options.numbers.absolute = absolute;
  if (args.WasGiven("rel")) options.numbers.relative = relative;
  for (const char* name : {"translation-m", "rotation-deg", "abs", "rel"}) {
    if (args.WasGiven(name)) options.use_tolerances = true;
  }
  for (std::string_view pattern : SplitFields(ignore, ',')) {
    if (!pattern.empty()) options.ignore_files.emplace_back(pattern);
  }

  const RegressReport report = CompareRunFolders(baseline, candidate, options);
  std::cout << FormatRegressReport(report, options);
  return report.Equal() ? kExitOk : kExitDifferent;
}

const CommandRegistrar kRegistrar("regress", {"compare two run folders, byte for byte or within tolerances",
                                              RunRegress});

}  // namespace
}  // namespace mcvo::tools
