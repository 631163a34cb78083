// Config JSON <-> PipelineOptions. One Visit() per options struct lists its
// keys in file order; a reading and a writing visitor walk the same lists, so
// the parser, the writer and the unknown-key check cannot disagree.
#include "mcvo/config/config.h"

#include <limits>

#include "mcvo/io/json_util.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

using io_internal::JoinPath;
using io_internal::Json;
using io_internal::JsonReader;
using OJson = nlohmann::ordered_json;

template <typename V>
void Visit(V& v, TextureOptions* o) {
  v.Field("min_gradient", &o->min_gradient);
  v.Field("noise_factor", &o->noise_factor);
}

template <typename V>
void Visit(V& v, ClaheOptions* o) {
  v.Field("enabled", &o->enabled);
  v.Field("clip_limit", &o->clip_limit);
  v.Field("tile_grid", &o->tile_grid);
}

template <typename V>
void Visit(V& v, LkOptions* o) {
  v.Field("window_px", &o->window_px);
  v.Field("pyramid_levels", &o->pyramid_levels);
  v.Field("max_iterations", &o->max_iterations);
  v.Field("forward_backward_check", &o->forward_backward_check);
  v.Field("forward_backward_threshold_px", &o->forward_backward_threshold_px);
  v.Field("predict_rotation", &o->predict_rotation);
  v.Field("predict_rotation_min_px", &o->predict_rotation_min_px);
  v.Field("predict_motion", &o->predict_motion);
  v.Field("predict_motion_min_px", &o->predict_motion_min_px);
  v.Field("predict_motion_min_points", &o->predict_motion_min_points);
}

template <typename V>
void Visit(V& v, AnchorOptions* o) {
  v.Field("enabled", &o->enabled);
  v.Field("half_size_px", &o->half_size_px);
  v.Field("weight_sigma_px", &o->weight_sigma_px);
  v.Field("max_iterations", &o->max_iterations);
  v.Field("min_zncc", &o->min_zncc);
  v.Field("max_shift_px", &o->max_shift_px);
  v.Field("max_warp_change", &o->max_warp_change);
  v.Field("reanchor_scale", &o->reanchor_scale);
  v.Field("drop_mismatch", &o->drop_mismatch);
}

template <typename V>
void Visit(V& v, SuperPointOptions* o) {
  v.Field("downscale", &o->downscale);
  v.Field("confidence_threshold", &o->confidence_threshold);
  v.Field("nms_radius_px", &o->nms_radius_px);
  v.Field("border_px", &o->border_px);
  v.Field("detect_missing_fraction", &o->detect_missing_fraction);
}

template <typename V>
void Visit(V& v, CrossCameraOptions* o) {
  v.Field("enabled", &o->enabled);
  v.Field("min_view_overlap", &o->min_view_overlap);
  v.Field("init_distance_m", &o->init_distance_m);
  v.Field("near_distance_m", &o->near_distance_m);
  v.Field("equalised", &o->equalised);
  v.Field("normalise_sigma_px", &o->normalise_sigma_px);
  v.Field("epipolar_threshold_px", &o->epipolar_threshold_px);
  v.Field("min_angle_deg", &o->min_angle_deg);
  v.Field("max_matches_per_pair", &o->max_matches_per_pair);
  v.Field("rematch_every", &o->rematch_every);
  v.Field("rematch_below_fraction", &o->rematch_below_fraction);
}

template <typename V>
void Visit(V& v, FrontendOptions* o) {
  v.Enum("detector", &o->detector, kDetectorTypeNames);
  v.Field("model_path", &o->model_path);
  v.Field("max_features_pinhole", &o->max_features_pinhole);
  v.Field("max_features_fisheye", &o->max_features_fisheye);
  v.Field("max_features_pinhole_megapixels", &o->max_features_pinhole_megapixels);
  v.Field("min_distance_px", &o->min_distance_px);
  v.Field("pixel_scale_reference_px", &o->pixel_scale_reference_px);
  v.Enum("selection", &o->selection, kFeatureSelectionNames);
  v.Field("candidate_factor", &o->candidate_factor);
  v.Field("detection_max_megapixels", &o->detection_max_megapixels);
  v.Field("detect_missing_fraction", &o->detect_missing_fraction);
  v.Field("ransac_threshold_px", &o->ransac_threshold_px);
  v.Field("ransac_focal_px", &o->ransac_focal_px);
  v.Section("clahe", &o->clahe);
  v.Section("texture", &o->texture);
  v.Section("lk", &o->lk);
  v.Section("anchor", &o->anchor);
  v.Section("superpoint", &o->superpoint);
  v.Section("cross_camera", &o->cross_camera);
}

template <typename V>
void Visit(V& v, CameraSfmOptions* o) {
  v.Field("ransac_threshold_px", &o->ransac_threshold_px);
  v.Field("focal_px", &o->focal_px);
  v.Field("ransac_max_iterations", &o->ransac_max_iterations);
  v.Field("min_correspondences", &o->min_correspondences);
  v.Field("min_inliers", &o->min_inliers);
  v.Field("min_triangulation_angle_deg", &o->min_triangulation_angle_deg);
  v.Field("min_points_for_pnp", &o->min_points_for_pnp);
  v.Field("max_reprojection_px", &o->max_reprojection_px);
  v.Field("max_ba_iterations", &o->max_ba_iterations);
  v.Field("ba_huber_px", &o->ba_huber_px);
}

template <typename V>
void Visit(V& v, RigConsistencyOptions* o) {
  v.Field("min_landmarks", &o->min_landmarks);
  v.Field("disagreement_sigmas", &o->disagreement_sigmas);
  v.Field("min_disagreement", &o->min_disagreement);
  v.Field("max_shape_residual", &o->max_shape_residual);
}

template <typename V>
void Visit(V& v, OverlapStartOptions* o) {
  v.Field("enable", &o->enable);
  v.Field("after_failed_windows", &o->after_failed_windows);
  v.Field("min_points", &o->min_points);
  v.Field("min_angle_deg", &o->min_angle_deg);
  v.Field("max_depth_m", &o->max_depth_m);
  v.Field("min_frame_inliers", &o->min_frame_inliers);
  v.Field("max_relative_scale_sigma", &o->max_relative_scale_sigma);
}

template <typename V>
void Visit(V& v, InitializerOptions* o) {
  v.Field("window_size", &o->window_size);
  v.Field("min_correspondences", &o->min_correspondences);
  v.Field("min_parallax_px", &o->min_parallax_px);
  v.Field("virtual_focal_px", &o->virtual_focal_px);
  v.Field("min_cameras_passing", &o->min_cameras_passing);
  v.NamesOrAll("required_cameras", &o->required_cameras);
  v.Field("relax_required_after_windows", &o->relax_required_after_windows);
  v.Field("min_cross_camera_matches", &o->min_cross_camera_matches);
  v.Field("min_cross_camera_angle_deg", &o->min_cross_camera_angle_deg);
  v.Field("min_singular_value_ratio", &o->min_singular_value_ratio);
  v.Field("max_rms_residual_m", &o->max_rms_residual_m);
  v.Field("max_relative_scale_sigma", &o->max_relative_scale_sigma);
  v.Field("max_relative_scale_sigma_fallback", &o->max_relative_scale_sigma_fallback);
  v.Field("monocular_fallback", &o->monocular_fallback);
  v.Field("max_skipped_windows", &o->max_skipped_windows);
  v.Field("max_rig_ba_iterations", &o->max_rig_ba_iterations);
  v.Section("sfm", &o->sfm);
  v.Section("consistency", &o->consistency);
  v.Section("overlap_start", &o->overlap_start);
}

template <typename V>
void Visit(V& v, BackendOptions* o) {
  v.Field("window_size", &o->window_size);
  v.Enum("solver", &o->solver, kSolverTypeNames);
  v.Field("max_iterations", &o->max_iterations);
  v.Field("max_solver_time_s", &o->max_solver_time_s);
  v.Enum("loss", &o->loss, kLossTypeNames);
  v.Field("loss_scale", &o->loss_scale);
  v.Field("reprojection_sigma_px", &o->reprojection_sigma_px);
  v.Field("virtual_focal_px", &o->virtual_focal_px);
  v.Field("init_depth_m", &o->init_depth_m);
  v.Field("min_observations", &o->min_observations);
  v.Field("keyframe_parallax_px", &o->keyframe_parallax_px);
  v.Field("keyframe_min_tracked", &o->keyframe_min_tracked);
  v.Field("outlier_threshold_px", &o->outlier_threshold_px);
  v.Field("cross_camera_min_angle_deg", &o->cross_camera_min_angle_deg);
  v.Field("pnp_threshold_px", &o->pnp_threshold_px);
  v.Field("min_pnp_inliers", &o->min_pnp_inliers);
  v.Field("scale_correction_period", &o->scale_correction_period);
  v.Field("scale_correction_min_change", &o->scale_correction_min_change);
  v.Field("scale_drift_per_100m", &o->scale_drift_per_100m);
  v.Field("scale_correction_max_sigma", &o->scale_correction_max_sigma);
  v.Field("scale_correction_sigma_factor", &o->scale_correction_sigma_factor);
  v.Field("scale_correction_min_rotation_deg", &o->scale_correction_min_rotation_deg);
  v.Field("scale_correction_min_travel_m", &o->scale_correction_min_travel_m);
  v.Field("refine_extrinsics", &o->refine_extrinsics);
  v.Field("reverse_pass", &o->reverse_pass);
  v.Field("reverse_pass_overlap_frames", &o->reverse_pass_overlap_frames);
  v.Field("reverse_pass_seeded", &o->reverse_pass_seeded);
}

template <typename V>
void Visit(V& v, DatasetSelectionOptions* o) {
  v.NamesOrAll("cameras", &o->cameras);
}

template <typename V>
void Visit(V& v, PoseGraphOptions* o) {
  v.Field("sim3", &o->sim3);
  v.Field("odometry_rotation_sigma_deg_per_m", &o->odometry_rotation_sigma_deg_per_m);
  v.Field("odometry_translation_sigma_per_m", &o->odometry_translation_sigma_per_m);
  v.Field("odometry_rotation_sigma_floor_deg", &o->odometry_rotation_sigma_floor_deg);
  v.Field("odometry_translation_sigma_floor_m", &o->odometry_translation_sigma_floor_m);
  v.Field("odometry_scale_sigma_per_m", &o->odometry_scale_sigma_per_m);
  v.Field("odometry_scale_sigma_floor", &o->odometry_scale_sigma_floor);
  v.Field("loop_rotation_sigma_deg", &o->loop_rotation_sigma_deg);
  v.Field("loop_translation_sigma_m", &o->loop_translation_sigma_m);
  v.Field("loop_scale_sigma", &o->loop_scale_sigma);
  v.Field("loop_loss_scale", &o->loop_loss_scale);
  v.Field("loop_loss_stages", &o->loop_loss_stages);
  v.Field("loop_loss_stage_factor", &o->loop_loss_stage_factor);
  v.Field("max_iterations", &o->max_iterations);
}

template <typename V>
void Visit(V& v, CrossCameraLinkOptions* o) {
  v.Field("window_keyframes", &o->window_keyframes);
  v.Field("radius_px", &o->radius_px);
  v.Field("max_distance", &o->max_distance);
  v.Field("ratio", &o->ratio);
  v.Field("max_scale_error", &o->max_scale_error);
  v.Field("max_reprojection_px", &o->max_reprojection_px);
  v.Field("min_parallax_deg", &o->min_parallax_deg);
  v.Field("max_view_angle_deg", &o->max_view_angle_deg);
  v.Field("overlapping_pairs", &o->overlapping_pairs);
  v.Field("max_pair_overlap", &o->max_pair_overlap);
}

template <typename V>
void Visit(V& v, LoopOptions* o) {
  v.Field("enabled", &o->enabled);
  v.Field("vocabulary_path", &o->vocabulary_path);
  v.Field("relocalise", &o->relocalise);
  v.Field("relocalise_map_keyframes", &o->relocalise_map_keyframes);
  v.Field("relocalise_query_keyframes", &o->relocalise_query_keyframes);
  v.Field("frontend_cache_mb", &o->frontend_cache_mb);
  LoopClosureOptions& c = o->closure;
  v.Field("features_per_camera", &c.features_per_camera);
  v.Field("feature_max_megapixels", &c.feature_max_megapixels);
  v.Field("exclude_recent_keyframes", &c.exclude_recent_keyframes);
  v.Field("min_score", &c.min_score);
  v.Field("min_normalized_score", &c.min_normalized_score);
  v.Field("max_candidates", &c.max_candidates);
  v.Field("landmark_levels", &c.landmark_levels);
  v.Field("landmark_orientation", &c.landmark_orientation);
  v.Field("match_ratio", &c.match_ratio);
  v.Field("max_match_distance", &c.max_match_distance);
  v.Field("pnp_threshold_px", &c.pnp_threshold_px);
  v.Field("pnp_max_iterations", &c.pnp_max_iterations);
  v.Field("min_inliers", &c.min_inliers);
  v.Field("min_camera_inliers", &c.min_camera_inliers);
  v.Field("min_camera_fraction", &c.min_camera_fraction);
  v.Field("consistency_window", &c.consistency_window);
  v.Field("candidate_neighbours", &c.candidate_neighbours);
  v.Field("max_correction_fraction", &c.max_correction_fraction);
  v.Field("max_correction_floor_m", &c.max_correction_floor_m);
  v.Section("cross_camera", &c.cross_camera);
  v.Section("pose_graph", &o->pose_graph);
}

template <typename V>
void Visit(V& v, GlobalBaOptions* o) {
  v.Field("enabled", &o->enabled);
  v.Field("monocular", &o->monocular);
  v.Field("max_iterations", &o->max_iterations);
  v.Field("outlier_rounds", &o->outlier_rounds);
  v.Field("first_solve_function_tolerance", &o->first_solve_function_tolerance);
  v.Field("inner_iterations", &o->inner_iterations);
  v.Enum("loss", &o->loss, kLossTypeNames);
  v.Field("loss_scale", &o->loss_scale);
  v.Field("adaptive_loss_sigmas", &o->adaptive_loss_sigmas);
  v.Field("adaptive_loss_min_px", &o->adaptive_loss_min_px);
  v.Field("reprojection_sigma_px", &o->reprojection_sigma_px);
  v.Field("virtual_focal_px", &o->virtual_focal_px);
  v.Field("outlier_threshold_px", &o->outlier_threshold_px);
  v.Field("min_observations", &o->min_observations);
  v.Field("function_tolerance", &o->function_tolerance);
  v.Field("thin_tracks_longer_than", &o->thin_tracks_longer_than);
  v.Field("thin_track_stride", &o->thin_track_stride);
  v.Field("fuse_loop_landmarks", &o->fuse_loop_landmarks);
  v.Field("straight_scale_sigma", &o->straight_scale_sigma);
  v.Field("straight_max_rotation_deg", &o->straight_max_rotation_deg);
  v.Field("straight_window_keyframes", &o->straight_window_keyframes);
  v.Field("straight_overlap_min_landmarks", &o->straight_overlap_min_landmarks);
  v.Field("cross_camera_link_sigma_px", &o->cross_camera_link_sigma_px);
  v.Field("refine_extrinsics", &o->refine_extrinsics);
  v.Field("extrinsic_rotation_sigma_deg", &o->extrinsic_rotation_sigma_deg);
  v.Field("extrinsic_translation_sigma_m", &o->extrinsic_translation_sigma_m);
}

template <typename V>
void Visit(V& v, OutputOptions* o) {
  v.Field("report", &o->report);
}

template <typename V>
void Visit(V& v, ColmapOutputOptions* o) {
  v.Field("enabled", &o->enabled);
  ColmapExportOptions& e = o->export_options;
  v.Enum("image_mode", &e.image_mode, kColmapImageModeNames);
  v.Enum("format", &e.format, kColmapModelFormatNames);
  v.Field("write_rig_files", &e.write_rig_files);
  v.Enum("fisheye_policy", &e.fisheye_policy, kColmapFisheyePolicyNames);
  v.Field("fisheye_max_angle_deg", &e.fisheye_max_angle_deg);
  v.Field("fit_grid", &e.fit_grid);
  v.Field("undistort_fov_deg", &e.undistort_fov_deg);
  v.Field("min_track_length", &e.min_track_length);
  v.Field("sample_colors", &e.sample_colors);
}

template <typename V>
void Visit(V& v, RuntimeOptions* o) {
  v.Field("threads", &o->threads);
  v.Field("seed", &o->seed);
  v.Field("deterministic", &o->deterministic);
}

template <typename V>
void Visit(V& v, EvalOptions* o) {
  v.Enum("align", &o->align, kAlignmentModeNames);
  v.Field("max_dt_s", &o->association.max_dt_s);
  v.Field("align_num_poses", &o->align_num_poses);
  v.Field("rpe_lengths_m", &o->rpe_lengths_m);
  v.Field("rpe_length_percents", &o->rpe_length_percents);
  v.Field("rpe_length_tolerance", &o->rpe_length_tolerance);
  v.Field("local_scale_window", &o->local_scale_window);
  v.Field("local_scale_min_distance_m", &o->local_scale_min_distance_m);
}

template <typename V>
void Visit(V& v, PipelineOptions* o) {
  v.Section("dataset", &o->dataset);
  v.Section("frontend", &o->frontend);
  v.Section("initializer", &o->initializer);
  v.Section("backend", &o->backend);
  v.Section("loop", &o->loop);
  v.Section("refine", &o->refine);
  v.Section("output", &o->output);
  v.Section("colmap", &o->colmap);
  v.Section("runtime", &o->runtime);
  v.Section("eval", &o->eval);
}

// Overlays the keys present in one JSON object onto a section.
class ReadVisitor {
 public:
  ReadVisitor(const JsonReader& reader, const Json& object, std::string path)
      : reader_(reader), object_(object), path_(std::move(path)) {}

  void Field(const char* key, bool* value) {
    if (const Json* j = Find(key)) *value = reader_.Bool(*j, Path(key));
  }
  void Field(const char* key, int* value) {
    if (const Json* j = Find(key)) {
      *value = static_cast<int>(
          reader_.Integer(*j, Path(key), std::numeric_limits<int>::min(), std::numeric_limits<int>::max()));
    }
  }
  void Field(const char* key, int64_t* value) {
    if (const Json* j = Find(key)) {
      *value = reader_.Integer(*j, Path(key), std::numeric_limits<int64_t>::min(),
                               std::numeric_limits<int64_t>::max());
    }
  }
  void Field(const char* key, double* value) {
    if (const Json* j = Find(key)) *value = reader_.Number(*j, Path(key));
  }
  void Field(const char* key, std::string* value) {
    if (const Json* j = Find(key)) *value = reader_.String(*j, Path(key));
  }
  void Field(const char* key, std::vector<double>* value) {
    if (const Json* j = Find(key)) *value = reader_.Numbers(*j, Path(key));
  }
  template <typename E, size_t N>
  void Enum(const char* key, E* value, const EnumName<E> (&table)[N]) {
    const Json* j = Find(key);
    if (j == nullptr) return;
    const std::string name = reader_.String(*j, Path(key));
    std::string valid;
    for (const EnumName<E>& entry : table) {
      if (name == entry.name) {
        *value = entry.value;
        return;
      }
      valid += std::string(valid.empty() ? "" : ", ") + "\"" + entry.name + "\"";
    }
    reader_.Fail(Path(key), "unknown value \"" + name + "\" (valid: " + valid + ")");
  }
  void NamesOrAll(const char* key, std::vector<std::string>* value) {
    const Json* j = Find(key);
    if (j == nullptr) return;
    if (j->is_string() && j->get<std::string>() == "all") {
      value->clear();
      return;
    }
    if (!j->is_array())
      reader_.Fail(Path(key),
                   "expected \"all\" or an array of camera names, got " + io_internal::DescribeJson(*j));
    value->clear();
    for (size_t i = 0; i < j->size(); ++i) value->push_back(reader_.String((*j)[i], JoinPath(Path(key), i)));
  }
  template <typename S>
  void Section(const char* key, S* section) {
    const Json* j = Find(key);
    if (j == nullptr) return;
    reader_.ExpectObject(*j, Path(key));
    ReadVisitor sub(reader_, *j, Path(key));
    Visit(sub, section);
    sub.RejectUnknownKeys();
  }

  void RejectUnknownKeys() const {
    std::vector<std::string> valid(keys_.begin(), keys_.end());
    reader_.CheckKeys(object_, path_, valid, {});
  }

 private:
  const Json* Find(const char* key) {
    keys_.emplace_back(key);
    const auto it = object_.find(key);
    return it == object_.end() ? nullptr : &*it;
  }
  std::string Path(const char* key) const { return JoinPath(path_, key); }

  const JsonReader& reader_;
  const Json& object_;
  std::string path_;
  std::vector<std::string> keys_;  // every key of the section, in file order
};

class WriteVisitor {
 public:
  template <typename T>
  void Field(const char* key, T* value) {
    object_[key] = *value;
  }
  template <typename E, size_t N>
  void Enum(const char* key, E* value, const EnumName<E> (&table)[N]) {
    object_[key] = EnumToName(table, *value);
  }
  void NamesOrAll(const char* key, std::vector<std::string>* value) {
    if (value->empty()) {
      object_[key] = "all";
    } else {
      object_[key] = *value;
    }
  }
  template <typename S>
  void Section(const char* key, S* section) {
    WriteVisitor sub;
    Visit(sub, section);
    object_[key] = std::move(sub.object_);
  }
  OJson& object() { return object_; }

 private:
  OJson object_ = OJson::object();
};

}  // namespace

PipelineOptions ParsePipelineOptions(const std::string& json_text, const std::string& source) {
  const JsonReader reader(source);
  const Json root = io_internal::ParseJson(json_text, source);
  reader.ExpectObject(root, "");
  PipelineOptions options;
  ReadVisitor visitor(reader, root, "");
  Visit(visitor, &options);
  visitor.RejectUnknownKeys();
  try {
    options.Check();
  } catch (const InputError& e) {
    throw InputError(source + ": " + e.what());
  }
  return options;
}

PipelineOptions ReadPipelineOptions(const std::filesystem::path& path) {
  return ParsePipelineOptions(ReadFileToString(path), path.string());
}

std::string PipelineOptionsToJson(const PipelineOptions& options) {
  PipelineOptions copy = options;
  WriteVisitor visitor;
  Visit(visitor, &copy);
  return io_internal::PrettyJson(visitor.object());
}

void WritePipelineOptions(const std::filesystem::path& path, const PipelineOptions& options) {
  WriteFileAtomic(path, PipelineOptionsToJson(options));
}

}  // namespace mcvo
