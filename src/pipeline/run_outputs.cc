#include "run_outputs.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <set>
#include <string_view>
#include <utility>

#include <nlohmann/json.hpp>

#include "mcvo/colmap/colmap_model.h"
#include "mcvo/config/config.h"
#include "mcvo/eval/report.h"
#include "mcvo/eval/report_html.h"
#include "mcvo/io/json_util.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/pipeline/run_manifest.h"
#include "mcvo/util/blas.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/output_folder.h"
#include "mcvo/util/sha256.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"

namespace mcvo::pipeline_internal {
namespace {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::ordered_json;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

Trajectory PosesTrajectory(const std::map<int, StampedPose>& poses) {
  Trajectory trajectory;
  trajectory.has_time = true;
  trajectory.has_frame_index = true;
  for (const auto& [frame_index, pose] : poses) trajectory.poses.push_back(pose);
  return trajectory;
}

// The keyframes' rig poses, in frame order.
Trajectory KeyframeTrajectory(const std::vector<KeyframeEstimate>& keyframes) {
  Trajectory trajectory;
  trajectory.has_time = true;
  trajectory.has_frame_index = true;
  for (const KeyframeEstimate& kf : keyframes) {
    StampedPose pose;
    pose.t_ns = kf.t_ns;
    pose.frame_index = kf.frame_index;
    pose.world_from_body = kf.world_from_rig;
    trajectory.poses.push_back(pose);
  }
  std::sort(trajectory.poses.begin(), trajectory.poses.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.frame_index < b.frame_index; });
  return trajectory;
}

std::string ScaleLogCsv(const Rig& rig, const std::vector<ScaleLogEntry>& scale_log) {
  std::string csv = "frame,t_ns,segment,event,applied";
  for (const Camera& camera : rig.cameras) csv += ",scale_" + camera.name;
  csv +=
      ",measured_ratio,measured_sigma,gain,applied_ratio,scale_sigma,rms_residual_m,singular_value_ratio,"
      "rms_reprojection_px,note\n";
  for (const ScaleLogEntry& e : scale_log) {
    csv += StrCat(e.frame_index, ",", e.t_ns, ",", e.segment, ",", e.event, ",", e.applied ? 1 : 0);
    for (int c = 0; c < rig.NumCameras(); ++c) {
      csv += ",";
      if (c < static_cast<int>(e.camera_scales.size())) csv += FormatDouble(e.camera_scales[c]);
    }
    csv += StrCat(",", FormatDouble(e.measured_ratio), ",", FormatDouble(e.measured_sigma), ",",
                  FormatDouble(e.gain), ",", FormatDouble(e.applied_ratio), ",", FormatDouble(e.scale_sigma),
                  ",", FormatDouble(e.rms_residual_m), ",", FormatDouble(e.singular_value_ratio), ",",
                  FormatDouble(e.rms_reprojection_px), ",", CsvQuote(e.note), "\n");
  }
  return csv;
}

// The trajectories a run writes: the final one, and the earlier stages'
// when a later stage changed them.
struct StageTrajectories {
  Trajectory final;              // trajectory.tum
  std::optional<Trajectory> vo;  // trajectory_vo.tum: the odometry (loop closure or refinement applied)
  // trajectory_loop.tum: after the pose graph, before refinement (both applied).
  std::optional<Trajectory> loop;
};

struct Evaluations {
  std::optional<EvalResult> final;     // trajectory.tum
  std::optional<EvalResult> odometry;  // trajectory_vo.tum
  std::optional<EvalResult> loop;      // trajectory_loop.tum
};

// eval/ (and eval_vo/, eval_loop/ for the earlier stages' trajectories)
// against the dataset's ground truth; the summary's accuracy fields. A
// ground truth that does not cover the run skips the evaluation with a
// warning.
Evaluations Evaluate(const RunOutputsInput& in, const StageTrajectories& trajectories,
                     const std::filesystem::path& dir, RunSummary* summary) {
  const Trajectory& trajectory = trajectories.final;
  Evaluations out;
  const DatasetIndex& index = *in.index;
  EvalOptions options = in.request->options.eval;
  // An arbitrary scale: a rigid alignment would measure the unit, not the
  // odometry; a similarity aligns it (and says so).
  if (summary->scale_arbitrary &&
      (options.align == AlignmentMode::kSe3 || options.align == AlignmentMode::kPosYaw)) {
    MCVO_LOG(kInfo, "run: evaluation: one camera, arbitrary scale: sim3 alignment instead of ",
             AlignmentModeName(options.align));
    options.align = AlignmentMode::kSim3;
  }
  summary->alignment = options.align;
  if (!index.ground_truth || trajectory.poses.size() < MinPosesForAlignment(options.align)) return out;
  try {
    out.final = EvaluateTrajectory(*index.ground_truth, trajectory, options,
                                   (index.root / "groundtruth").string(), "trajectory.tum");
    const std::string arbitrary_note =
        "the estimate's scale is arbitrary (one camera, monocular): its size relative to the truth is its "
        "unit, not an error";
    if (summary->scale_arbitrary) out.final->notes.push_back(arbitrary_note);
    const EvalResult& result = *out.final;
    CreateDirectories(dir / "eval");
    WriteEvalOutputs(dir / "eval", result);
    summary->evaluated = true;
    summary->ate_rmse_m = result.ate_translation_m.rmse;
    summary->gt_path_length_m = result.gt_matched_path_length_m;
    summary->ate_percent_of_path =
        summary->gt_path_length_m > 0 ? 100.0 * summary->ate_rmse_m / summary->gt_path_length_m : 0.0;
    summary->scale_error_percent = result.scale.scale_error_percent;
    if (result.scale.available) summary->unit_m = result.scale.sim3_scale;
    const auto evaluate_stage = [&](const Trajectory& stage, const char* file, const char* folder) {
      EvalResult stage_result = EvaluateTrajectory(*index.ground_truth, stage, options,
                                                   (index.root / "groundtruth").string(), file);
      if (summary->scale_arbitrary) stage_result.notes.push_back(arbitrary_note);
      CreateDirectories(dir / folder);
      WriteEvalOutputs(dir / folder, stage_result);
      return stage_result;
    };
    if (trajectories.vo) out.odometry = evaluate_stage(*trajectories.vo, "trajectory_vo.tum", "eval_vo");
    if (trajectories.loop) out.loop = evaluate_stage(*trajectories.loop, "trajectory_loop.tum", "eval_loop");
  } catch (const InputError& e) {
    MCVO_LOG(kWarning, "run: evaluation skipped: ", e.what());
  }
  return out;
}

// The COLMAP model of the keyframes and landmarks in dir/colmap; what
// run.json says of it.
Json ExportColmap(const RunOutputsInput& in, const std::filesystem::path& dir, double* seconds) {
  Json colmap_json;
  const DatasetIndex& index = *in.index;
  const Rig& rig = index.rig;
  const SparseMap& map = *in.map;
  const std::filesystem::path& absolute_out = in.final_dir;
  const int threads = in.threads;
  ColmapExportOptions colmap_options = in.request->options.colmap.export_options;
  colmap_options.threads = threads;
  const Clock::time_point colmap_start = Clock::now();
  const ColmapExportReport colmap =
      WriteColmapModel(rig, map, std::filesystem::absolute(index.root).lexically_normal(), colmap_options,
                       dir / "colmap", in.loops != nullptr ? &in.loops->colors : nullptr);
  *seconds = SecondsSince(colmap_start);
  // The description names the staging folder: say "<out>/colmap" instead.
  std::string description = DescribeColmapExport(colmap);
  const std::string staged = (dir / "colmap").string();
  for (size_t at = description.find(staged); at != std::string::npos; at = description.find(staged, at)) {
    description.replace(at, staged.size(), (absolute_out / "colmap").string());
  }
  for (std::string_view line : SplitFields(description, '\n')) {
    if (!Trim(line).empty()) MCVO_LOG(kInfo, "run: colmap: ", line);
  }
  colmap_json["images"] = colmap.images;
  colmap_json["points"] = colmap.points;
  colmap_json["observations"] = colmap.observations;
  colmap_json["mean_track_length"] = colmap.mean_track_length;
  colmap_json["mean_reprojection_error_px"] = colmap.mean_reprojection_error_px;
  colmap_json["observations_dropped"] = colmap.observations_dropped;
  colmap_json["landmarks_dropped"] = colmap.landmarks_dropped;
  nlohmann::ordered_json cameras_json = nlohmann::ordered_json::array();
  for (const ColmapCameraExport& camera : colmap.camera_exports) {
    nlohmann::ordered_json c;
    c["name"] = camera.name;
    c["model"] = std::string(ColmapCameraModelName(camera.camera.model));
    c["fitted"] = camera.fitted;
    c["undistorted"] = camera.undistorted;
    if (camera.fitted) {
      c["fit_rms_px"] = camera.fit_rms_px;
      c["fit_max_px"] = camera.fit_max_px;
    }
    c["observations_written"] = camera.observations_written;
    c["observations_dropped"] = camera.observations_dropped;
    cameras_json.push_back(c);
  }
  colmap_json["cameras"] = cameras_json;
  colmap_json["notes"] = colmap.notes;
  return colmap_json;
}

// One line on the global bundle adjustment for the report.
std::string GlobalBaSummary(const RunOutputsInput& in) {
  if (in.refine == nullptr || !in.refine->applied) {
    return in.refine != nullptr && !in.refine->ba.message.empty() ? "not run: " + in.refine->ba.message
                                                                  : "off";
  }
  const GlobalBaResult& ba = in.refine->ba;
  return StrCat(ba.keyframes_refined, " keyframes, ", ba.landmarks_refined, " landmarks, ",
                ba.observations_used, " observations (", ba.observations_removed, " removed as outliers), ",
                ba.constraints_used, " loop constraint(s); rms error ",
                FormatFixed(ba.rms_error_px_before, 3), " px before, ", FormatFixed(ba.rms_error_px_after, 3),
                " px after");
}

void WriteReport(const RunOutputsInput& in, const RunSummary& summary, const Evaluations& evals,
                 const StageTrajectories& trajectories, const Json& recorded_config,
                 const std::filesystem::path& dir) {
  const DatasetIndex& index = *in.index;
  const Rig& rig = index.rig;
  ReportInputs report;
  report.title = StrCat("mcvo run: ", index.name, ", ", rig.NumCameras(), " camera(s)");
  const bool loops_applied = in.loops != nullptr && in.loops->applied;
  report.before_label = loops_applied ? "odometry (before loop closure)" : "odometry (before global BA)";
  if (evals.final) {
    report.eval = &*evals.final;
    if (trajectories.vo) {
      report.estimate_before_loop_closure =
          ApplyAlignment(*trajectories.vo, evals.final->gt_world_from_est_world);
    }
    report.ground_truth = *index.ground_truth;
  } else {
    report.estimate = trajectories.final;
    report.estimate_before_loop_closure = trajectories.vo;
  }
  for (const ScaleLogEntry& e : in.odometry->scale_log) {
    report.scale_log.push_back(
        {e.frame_index, e.t_ns, e.segment, e.event, e.camera_scales, e.applied, e.note});
  }
  for (const Camera& camera : rig.cameras) report.camera_names.push_back(camera.name);
  report.settings = recorded_config;
  report.summary_rows = {
      {"program", StrCat("mcvo ", in.request->version)},
      {"dataset", StrCat(index.name, " (", index.format, ")")},
      {"input", in.request->tracks.empty() ? "images" : "track file"},
      {"frames", StrCat(summary.frames)},
      {"posed frames", StrCat(summary.posed_frames)},
      {"keyframes", StrCat(summary.keyframes)},
      {"segments", StrCat(summary.segments)},
      {"segments relocalised after a loss",
       StrCat(summary.segments_relocalised, " of ", summary.segments - 1)},
      {"posed by the reverse pass (scale applied back)", StrCat(in.odometry->reverse_posed.size())},
      {"global bundle adjustment", GlobalBaSummary(in)},
      {"scale", summary.scale_arbitrary
                    ? "arbitrary: one camera (monocular); the evaluation aligns with a similarity"
                    : "metric"}};
  if (!summary.warning.empty()) report.summary_rows.push_back({"warning", summary.warning});
  WriteReports(dir, report);
}

// SHA-256 of every file under dir but colmap/images/ (links to or copies
// of the input images, whose hashes are under "inputs", or images remapped
// from them), by relative path.
Json OutputsSha256(const std::filesystem::path& dir) {
  Json outputs;
  std::vector<std::filesystem::path> files;
  const std::filesystem::path colmap_images = dir / "colmap" / "images";
  for (auto it = std::filesystem::recursive_directory_iterator(dir);
       it != std::filesystem::recursive_directory_iterator(); ++it) {
    if (it->path() == colmap_images) {
      it.disable_recursion_pending();
      continue;
    }
    // The staging and output markers (util/output_folder.h) are the folder's, not outputs.
    const std::string name = it->path().filename().string();
    if (it.depth() == 0 && (name == kOutputMarkerName || name == kStagingMarkerName)) continue;
    if (!it->is_symlink() && it->is_regular_file()) files.push_back(it->path());
  }
  std::sort(files.begin(), files.end());
  for (const auto& path : files)
    outputs[std::filesystem::relative(path, dir).generic_string()] = Sha256File(path);
  return outputs;
}

// The worst local-scale deviation (eval.md "Local scale"), null without a window.
Json LocalScaleWorst(const EvalResult& eval) {
  return eval.local_scale.ratio.count > 0 ? Json(eval.local_scale.worst_deviation_percent) : Json(nullptr);
}

// run.json's result.global_ba: what the global bundle adjustment did, and
// the accuracy of the trajectory it started from.
Json GlobalBaJson(const RunOutputsInput& in, const RunSummary& summary, const Evaluations& evals) {
  const RefineOutcome& refine = *in.refine;
  const GlobalBaResult& ba = refine.ba;
  Json json;
  json["applied"] = refine.applied;
  if (!refine.applied) {
    if (!ba.message.empty()) json["not_run"] = ba.message;
    return json;
  }
  json["keyframes"] = ba.keyframes_refined;
  json["components"] = ba.components;
  json["loop_constraints"] = ba.constraints_used;
  json["straight_scale_residuals"] = ba.straight_scale_residuals;
  json["loop_landmarks_merged"] = refine.fusion.landmarks_merged;
  json["loop_observations_added"] = refine.fusion.observations_added;
  json["loop_merges_rejected"] = refine.fusion.merges_rejected;
  json["cross_camera_landmarks_merged"] = refine.cross_camera_fusion.landmarks_merged;
  json["cross_camera_merges_rejected"] = refine.cross_camera_fusion.merges_rejected;
  json["cross_camera_ties"] = refine.ba.ties_used;
  json["landmarks"] = ba.landmarks_refined;
  json["observations"] = ba.observations_used;
  json["observations_removed"] = ba.observations_removed;
  json["solves"] = ba.solves;
  json["loss_knee_px"] = ba.loss_knee_px;
  json["iterations"] = ba.iterations;
  json["initial_cost"] = ba.initial_cost;
  json["final_cost"] = ba.final_cost;
  json["rms_error_px_before"] = ba.rms_error_px_before;
  json["rms_error_px_after"] = ba.rms_error_px_after;
  json["solver_message"] = ba.message;
  if (refine.extrinsics_refined) {
    const Rig& rig = in.index->rig;  // the refined rig
    Json cameras = Json::array();
    for (size_t c = 0; c < rig.cameras.size() && c < ba.cam_from_rig.size(); ++c) {
      Json camera;
      camera["camera"] = rig.cameras[c].name;
      camera["reference"] = c == 0;
      camera["rotation_change_deg"] = ba.extrinsic_rotation_change_deg[c];
      camera["translation_change_m"] = ba.extrinsic_translation_change_m[c];
      cameras.push_back(camera);
    }
    json["extrinsics"] = cameras;
  }
  const std::optional<EvalResult>& before = evals.loop ? evals.loop : evals.odometry;
  if (before) {
    json["ate_rmse_m_before"] = before->ate_translation_m.rmse;
    if (!summary.scale_arbitrary) json["scale_error_percent_before"] = before->scale.scale_error_percent;
    json["local_scale_worst_percent_before"] = LocalScaleWorst(*before);
  }
  return json;
}

Json ResultJson(const RunOutputsInput& in, const RunSummary& summary, const Evaluations& evals) {
  const OdometryOutput& odometry = *in.odometry;
  Json result;
  result["frames"] = summary.frames;
  result["posed_frames"] = summary.posed_frames;
  result["keyframes"] = summary.keyframes;
  result["segments"] = summary.segments;
  result["segments_relocalised"] = summary.segments_relocalised;
  result["frames_posed_by_reverse_pass"] = odometry.reverse_posed.size();
  // "arbitrary": one camera (estimator.h "Monocular"): positions in a unit of
  // the initialisation, evaluated with a similarity, no scale error.
  result["scale"] = summary.scale_arbitrary ? "arbitrary" : "metric";
  // The trajectory's body when it is not the rig frame: the rig origin moved
  // (a one-camera rig: to the camera centre), in the dataset's rig frame,
  // metres; `mcvo eval --align auto` moves the ground truth by it.
  if (in.index->origin_moved_to) {
    const Eigen::Vector3d& c = *in.index->origin_moved_to;
    result["trajectory_origin_in_rig_m"] = Json::array({c.x(), c.y(), c.z()});
  }
  if (odometry.fallback_sigma > 0.0) result["initializer_fallback_sigma"] = odometry.fallback_sigma;
  if (odometry.monocular_camera >= 0) {
    result["monocular_fallback"] = StrCat(in.index->rig.cameras.front().name,
                                          " alone at an arbitrary scale: ", odometry.monocular_reason);
  }
  if (!summary.warning.empty()) result["warning"] = summary.warning;
  if (summary.evaluated) {
    result["ate_rmse_m"] = summary.ate_rmse_m;
    result["ate_percent_of_path"] = summary.ate_percent_of_path;
    result["alignment"] = std::string(AlignmentModeName(summary.alignment));
    if (summary.scale_arbitrary) {
      result["unit_m"] = summary.unit_m;
    } else {
      result["scale_error_percent"] = summary.scale_error_percent;
    }
    result["gt_path_length_m"] = summary.gt_path_length_m;
    if (evals.final) {
      result["local_scale_window_frames"] = evals.final->local_scale.window_poses;
      result["local_scale_worst_percent"] = LocalScaleWorst(*evals.final);
    }
  }
  result["sparse_map_keyframes"] = in.map->keyframes.size();
  result["sparse_map_landmarks"] = in.map->landmarks.size();
  result["sparse_map_observations_dropped"] = in.map_observations_dropped;
  if (in.loops != nullptr) {
    const LoopOutcome& loops = *in.loops;
    result["loop_candidates_verified"] = loops.verified;
    result["loops_accepted"] = loops.accepted;
    result["loop_closure_applied"] = loops.applied;
    result["cross_camera_links"] = loops.cross_camera_links.size();
    if (loops.applied && evals.odometry) {
      result["ate_rmse_m_before_loop_closure"] = evals.odometry->ate_translation_m.rmse;
      if (!summary.scale_arbitrary) {
        result["scale_error_percent_before_loop_closure"] = evals.odometry->scale.scale_error_percent;
      }
    }
  }
  if (in.refine != nullptr) result["global_ba"] = GlobalBaJson(in, summary, evals);
  return result;
}

Json TimingJson(const RunOutputsInput& in, const RunSummary& summary, double colmap_seconds) {
  const OdometryOutput& odometry = *in.odometry;
  const StageSeconds& totals = odometry.totals;
  Json timing;
  timing["note"] = "wall-clock, not deterministic; seconds per frame, means over the run";
  timing["threads"] = in.threads;
  timing["seconds_total"] = summary.seconds;
  timing["frames_per_second"] = summary.frames_per_second;
  const double n = std::max(1, summary.frames);
  timing["frontend_s"] = totals.frontend / n;
  if (in.frontend_stages != nullptr) {
    // As `mcvo track --timing`: seconds per frame, summed over the cameras.
    Json stages;
    for (const auto& [stage, value] : in.frontend_stages->PerFrame()) stages[stage] = value;
    timing["frontend_stages_s"] = stages;
  }
  timing["initializer_s"] = totals.initializer / n;
  timing["pnp_s"] = totals.pnp / n;
  timing["ba_s"] = totals.ba / n;
  timing["marginalization_s"] = totals.marginalization / n;
  timing["scale_correction_s"] = totals.scale / n;
  timing["backend_s"] = totals.backend / n;
  timing["colmap_export_s_total"] = colmap_seconds;
  timing["odometry_s_total"] = in.odometry_seconds;
  timing["reverse_pass_s_total"] = odometry.reverse_seconds;
  if (in.loops != nullptr) {
    const LoopOutcome& loops = *in.loops;
    const double keyframe_count = std::max<size_t>(1, odometry.keyframes.size());
    timing["loop_image_read_s_per_keyframe"] = loops.timing.input_s / keyframe_count;
    timing["loop_features_s_per_keyframe"] = loops.timing.features_s / keyframe_count;
    // Keyframes described during the odometry from the frontend's decode
    // (pipeline/loop_image_cache.h): how many, and that work per keyframe
    // of the run (part of odometry_s_total).
    timing["loop_keyframes_from_frontend_decode"] = loops.keyframes_from_cache;
    timing["loop_features_in_odometry_s_per_keyframe"] = loops.cache_seconds / keyframe_count;
    timing["loop_frontend_decode_mb"] = loops.cache_bytes / 1048576.0;
    timing["loop_query_s_per_keyframe"] = loops.timing.query_s / keyframe_count;
    timing["loop_verification_s_per_keyframe"] = loops.timing.verification_s / keyframe_count;
    timing["pose_graph_s_total"] = loops.pose_graph_seconds;
    timing["cross_camera_links_s_total"] = loops.timing.cross_camera_s;
  }
  if (in.refine != nullptr) timing["global_ba_s_total"] = in.refine->ba.seconds;
  return timing;
}

}  // namespace

// The run's sparse map: keyframes in frame order with their images and the
// observations of landmarks that have a final position and lie within
// kMapMaxErrorFactor x the back end's outlier threshold of it, measured as
// the back end does (the angle between the observed bearing and the
// direction to the landmark, in pixels at the virtual focal length); the
// landmarks they observe, in id order. The filter matters: an observation is
// recorded when its keyframe leaves the window, and the landmark goes on
// being refined after that (a track that slid onto another point is
// re-triangulated from its later observations).
constexpr double kMapMaxErrorFactor = 2.0;
SparseMap BuildSparseMap(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                         const std::map<int64_t, Eigen::Vector3d>& landmarks, const BackendOptions& backend,
                         int* dropped) {
  const Rig& rig = index.rig;
  const double max_angle_rad = kMapMaxErrorFactor * backend.outlier_threshold_px / backend.virtual_focal_px;
  *dropped = 0;
  SparseMap map;
  std::set<int64_t> observed;
  for (const KeyframeEstimate& kf : keyframes) {
    MapKeyframe out;
    out.frame_index = kf.frame_index;
    out.t_ns = kf.t_ns;
    out.segment = kf.segment;
    out.world_from_rig = kf.world_from_rig;
    if (kf.frame_index >= 0 && kf.frame_index < static_cast<int>(index.frames.size())) {
      // Absolute: the dataset's paths include its root, which may be relative.
      for (const std::filesystem::path& image : index.frames[static_cast<size_t>(kf.frame_index)].images) {
        out.images.push_back(image.empty() ? image : std::filesystem::absolute(image).lexically_normal());
      }
    }
    for (const MapObservation& ob : kf.observations) {
      auto landmark = landmarks.find(ob.landmark_id);
      if (landmark == landmarks.end()) continue;
      const Camera& camera = rig.cameras[static_cast<size_t>(ob.camera)];
      const Rigid3d cam_from_world = camera.cam_from_rig * kf.world_from_rig.Inverse();
      const std::optional<Eigen::Vector3d> bearing = camera.Unproject(ob.pixel);
      const Eigen::Vector3d direction = (cam_from_world * landmark->second).normalized();
      const double angle =
          bearing ? std::acos(std::clamp(bearing->normalized().dot(direction), -1.0, 1.0)) : M_PI;
      if (!(angle <= max_angle_rad)) {
        ++*dropped;
        continue;
      }
      out.observations.push_back(ob);
      observed.insert(ob.landmark_id);
    }
    map.keyframes.push_back(std::move(out));
  }
  std::stable_sort(map.keyframes.begin(), map.keyframes.end(),
                   [](const MapKeyframe& a, const MapKeyframe& b) { return a.frame_index < b.frame_index; });
  for (const auto& [id, position] : landmarks) {
    if (observed.count(id) != 0) map.landmarks.push_back({id, position});
  }
  return map;
}

void WriteRunOutputs(const RunOutputsInput& in, const std::filesystem::path& dir, RunSummary* summary) {
  const ScopedStage stage("writing the outputs");
  const RunRequest& request = *in.request;
  const PipelineOptions& options = request.options;
  const DatasetIndex& index = *in.index;
  const Rig& rig = index.rig;
  const OdometryOutput& odometry = *in.odometry;
  const bool loops_applied = in.loops != nullptr && in.loops->applied;

  // Trajectories (final, and each earlier stage's that a later one changed), logs, statistics.
  const bool refined = in.refine != nullptr && in.refine->applied;
  StageTrajectories trajectories;
  trajectories.final = PosesTrajectory(odometry.poses);
  const Trajectory& trajectory = trajectories.final;
  WriteTrajectory(dir / "trajectory.tum", trajectory, TrajectoryFormat::kTum);
  WriteTrajectory(dir / "trajectory_kitti.txt", trajectory, TrajectoryFormat::kKittiIndexed);
  WriteTrajectory(dir / "trajectory_euroc.csv", trajectory, TrajectoryFormat::kEuroc);
  WriteTrajectory(dir / "keyframes.tum", KeyframeTrajectory(odometry.keyframes), TrajectoryFormat::kTum);
  const OdometryBeforeLoops* odometry_only = loops_applied ? in.before_loops
                                             : refined     ? &in.refine->before
                                                           : nullptr;
  if (odometry_only != nullptr) {
    trajectories.vo = PosesTrajectory(odometry_only->poses);
    WriteTrajectory(dir / "trajectory_vo.tum", *trajectories.vo, TrajectoryFormat::kTum);
    WriteTrajectory(dir / "keyframes_vo.tum", KeyframeTrajectory(odometry_only->keyframes),
                    TrajectoryFormat::kTum);
  }
  if (loops_applied && refined) {
    trajectories.loop = PosesTrajectory(in.refine->before.poses);
    WriteTrajectory(dir / "trajectory_loop.tum", *trajectories.loop, TrajectoryFormat::kTum);
    WriteTrajectory(dir / "keyframes_loop.tum", KeyframeTrajectory(in.refine->before.keyframes),
                    TrajectoryFormat::kTum);
  }
  if (in.loops != nullptr) WriteFileAtomic(dir / "loops.csv", LoopsCsv(in.loops->attempts));
  if (in.loops != nullptr && !in.loops->cross_camera_links.empty()) {
    WriteFileAtomic(dir / "cross_camera_links.csv", CrossCameraLinksCsv(in.loops->cross_camera_links));
  }
  if (in.refine != nullptr && in.refine->extrinsics_refined) WriteRig(dir / "rig_refined.json", rig);
  WriteFileAtomic(dir / "scale_log.csv", ScaleLogCsv(rig, odometry.scale_log));
  WriteFileAtomic(dir / "frame_stats.csv", FrameStatsCsv(rig, odometry));
  WriteFileAtomic(dir / "timing.csv", TimingCsv(odometry));

  const Evaluations evals = Evaluate(in, trajectories, dir, summary);
  double colmap_seconds = 0.0;
  Json colmap_json;
  if (options.colmap.enabled) colmap_json = ExportColmap(in, dir, &colmap_seconds);

  // report.html / report.md: deterministic content only (no timings).
  PipelineOptions recorded = options;
  recorded.runtime.threads = 0;  // the thread count does not change the results
  const Json recorded_config = Json::parse(PipelineOptionsToJson(recorded));
  if (options.output.report) {
    WriteReport(in, *summary, evals, trajectories, recorded_config, dir);
  }

  // run.json: what was run, on what, what came out.
  RunManifest run;
  run.version = request.version;
  run.executable_sha256 = ExecutableSha256();
  run.blas = BlasLibrary();
  run.command_line = request.command_line;
  run.config_source = request.config_source;
  run.config = recorded_config;
  run.dataset.root = index.root.string();
  run.dataset.format = index.format;
  run.dataset.name = index.name;
  run.dataset.frames = in.total_frames;
  for (const Camera& camera : rig.cameras) run.dataset.cameras.push_back(camera.name);
  MCVO_CHECK(in.inputs != nullptr);
  for (const auto& [key, hash] : *in.inputs) run.inputs[key] = hash;
  const Json outputs = OutputsSha256(dir);
  for (const auto& item : outputs.items()) run.outputs_sha256[item.key()] = item.value().get<std::string>();
  run.result = ResultJson(in, *summary, evals);
  run.colmap = colmap_json;
  run.timing = TimingJson(in, *summary, colmap_seconds);
  WriteFileAtomic(dir / "run.json", io_internal::PrettyJson(run.ToJson()));
}

}  // namespace mcvo::pipeline_internal
