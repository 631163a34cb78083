// run.json of `mcvo run` (docs/run-outputs.md): what was run, on what, what
// came out. One type for its writer (the outputs stage of `mcvo run`) and
// its readers (`mcvo batch`: whether a finished run is up to date, and the
// numbers of its summary; `mcvo regress`: the outputs to compare; `mcvo
// eval --align auto`: whether the scale is arbitrary), so that the schema's
// keys are written down in one place (src/pipeline/run_manifest.cc).
//
// The result, colmap and timing sections are objects whose members are
// documented in docs/run-outputs.md; RunHeadline is the typed view of the
// result numbers the readers use.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace mcvo {

struct RunManifestDataset {
  std::string root;    // as opened
  std::string format;  // generic, kitti360, euroc, kalibr
  std::string name;
  int frames = -1;  // frames run (after --frames); -1: not recorded
  std::vector<std::string> cameras;
};

// The result numbers a summary shows (run.json "result", "timing").
struct RunHeadline {
  int frames = 0;
  int posed_frames = 0;
  int segments = 0;
  std::optional<std::string> warning;
  bool scale_arbitrary = false;  // result.scale == "arbitrary" (one camera)
  // Where the trajectory's origin is in the rig frame when it was moved
  // (a one-camera rig: the camera centre).
  std::optional<Eigen::Vector3d> trajectory_origin_in_rig_m;
  std::optional<double> ate_rmse_m;  // present: the run was evaluated
  std::optional<double> ate_percent_of_path;
  std::optional<double> scale_error_percent;
  std::optional<double> rpe_translation_percent;
  std::optional<double> rpe_rotation_deg_per_100m;
  std::optional<double> frames_per_second;
};

struct RunManifest {
  std::string program = "mcvo";
  std::string version;
  // SHA-256 of the executable that made the outputs ("build"): `mcvo batch`
  // runs a run again when it changes; `mcvo regress` ignores it.
  std::string executable_sha256;
  // The BLAS library the run was made with (mcvo/util/blas.h); with the
  // executable, what `mcvo batch` compares ("build").
  std::string blas;
  std::string command_line;
  std::string config_source;
  // JSON members keep the order they were written in (run.json reads as
  // the writer laid it out).
  nlohmann::ordered_json config;  // the PipelineOptions as run, threads recorded as 0
  RunManifestDataset dataset;
  std::map<std::string, std::string> inputs;          // input key -> SHA-256
  std::map<std::string, std::string> outputs_sha256;  // output file (relative) -> SHA-256
  nlohmann::ordered_json result = nlohmann::ordered_json::object();
  nlohmann::ordered_json colmap;  // null: no COLMAP export
  nlohmann::ordered_json timing = nlohmann::ordered_json::object();

  // The top-level members a read found, of the right type (FromJson); a
  // manifest built in code has them all.
  std::set<std::string> present = {"program",        "version", "build",   "command_line",
                                   "config_source",  "config",  "dataset", "inputs",
                                   "outputs_sha256", "result",  "timing"};
  bool Has(const std::string& member) const { return present.count(member) != 0; }

  // The members in run.json's order: program, version, build, command_line,
  // config_source, config, dataset, inputs, outputs_sha256, result,
  // colmap (when exported), timing.
  nlohmann::ordered_json ToJson() const;
  // Lenient: a member that is missing or of another type keeps its default
  // and is left out of `present`; the readers decide what they need.
  static RunManifest FromJson(const nlohmann::ordered_json& json);
  // Reads and parses `path`; throws InputError naming it when it does not
  // parse or is not a JSON object.
  static RunManifest Read(const std::filesystem::path& path);

  RunHeadline Headline() const;
};

}  // namespace mcvo
