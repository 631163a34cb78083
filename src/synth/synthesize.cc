#include "mcvo/synth/synthesize.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>
#include <string_view>
#include <system_error>
#include <utility>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mcvo/dataset/dataset.h"
#include "mcvo/io/frame_table.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/synth/scene.h"
#include "mcvo/synth/trajectory.h"
#include "mcvo/util/cancel.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/output_folder.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"

namespace mcvo::synth {
namespace internal {
// Generated from config/rigs/*.json (src/synth/embedded_rigs.cc.in).
const std::vector<std::pair<std::string_view, std::string_view>>& EmbeddedRigFiles();
}  // namespace internal

namespace {

// Removes a folder on scope exit unless released: a failed run leaves nothing.
std::string FrameFileName(int frame) {
  std::ostringstream name;
  name << std::setw(6) << std::setfill('0') << frame << ".png";
  return name.str();
}

void WritePng(const std::filesystem::path& path, const cv::Mat& image) {
  // Fixed compression settings: the same pixels always give the same bytes.
  const std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, 3};
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), image, params);
  } catch (const cv::Exception& e) {
    MCVO_THROW_INPUT(path.string(), ": cannot write PNG: ", e.what());
  }
  if (!ok) MCVO_THROW_INPUT(path.string(), ": cannot write PNG");
}

Rig ResolveRig(const SynthOptions& options) {
  Rig rig = options.preset.empty() ? ReadRig(options.rig_path) : PresetRig(options.preset);
  for (Camera& camera : rig.cameras) {
    // A user mask describes the user's real camera (a car hood, ...); the
    // synthetic images get the model's own valid-pixel mask instead.
    camera.mask_path.clear();
    if (options.image_scale != 1.0) camera = ScaledCamera(camera, options.image_scale);
  }
  return rig;
}

// Horizontal centre (rig x forward, y right; z = 0) of the box around the
// rig's camera centres: the point a person carrying the rig keeps on the
// corridor's centre line, so that the cameras swing least far from it.
Eigen::Vector3d CameraCentreInRig(const Rig& rig) {
  if (rig.cameras.empty()) return Eigen::Vector3d::Zero();
  Eigen::Vector3d low = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d high = -low;
  for (const Camera& camera : rig.cameras) {
    const Eigen::Vector3d centre = camera.cam_from_rig.Inverse().translation;
    low = low.cwiseMin(centre);
    high = high.cwiseMax(centre);
  }
  const Eigen::Vector3d middle = 0.5 * (low + high);
  return {middle.x(), middle.y(), 0.0};
}

// Throws UsageError when a camera is behind a wall in a frame to be
// rendered (`world_from_rig` at `times_ns`): the segment from the route
// point (on the centre line, in the room) to the camera centre must not
// cross the scene's static geometry, nor come within kWallClearanceM of it.
// Only scenes with a ceiling (rooms and corridors) are checked.
void CheckCamerasInRoom(const SceneWithRoute& world, const TrajectorySpec& spec, const Rig& rig,
                        const std::string& scene_name, const std::function<Rigid3d(int64_t)>& world_from_rig,
                        const std::vector<int64_t>& times_ns, double period_s) {
  if (!(world.ceiling_height_m > 0.0)) return;
  const Eigen::Vector3d carried(spec.route_point_in_rig.x(), spec.route_point_in_rig.y(), 0.0);
  for (const Camera& camera : rig.cameras) {
    int first = -1, frames = 0;
    double reach = 0.0;
    for (size_t k = 0; k < times_ns.size(); ++k) {
      const Rigid3d pose = world_from_rig(times_ns[k]);
      const Eigen::Vector3d route_point = pose * carried;
      const Eigen::Vector3d centre = (pose * camera.cam_from_rig.Inverse()).translation;
      const Eigen::Vector3d ray = centre - route_point;
      const double length = ray.norm();
      if (!(length > 1e-6)) continue;
      const std::optional<Hit> hit =
          world.scene.Intersect(route_point, ray / length, times_ns[k], 1e-4, length + kWallClearanceM);
      if (!hit || hit->moving_object >= 0) continue;
      if (first < 0) first = static_cast<int>(k);
      ++frames;
      reach = length;
    }
    if (frames == 0) continue;
    throw UsageError(StrCat("camera ", camera.name, " would be behind (or within ",
                            FormatFixed(kWallClearanceM, 2), " m of) a wall of scene '", scene_name, "' in ",
                            frames, " frame(s) from frame ", first, " (", FormatFixed(first * period_s, 2),
                            " s): it is ", FormatFixed(reach, 2),
                            " m from the rig's carrying point (the middle of its cameras), which follows the "
                            "route, and the scene's "
                            "corridors leave less; render fewer frames or another scene"));
  }
}

// The trajectory of RouteTrajectorySpec, fitted to a scene with a ceiling
// (rooms and corridors), where a rig built for a car is carried by hand:
//  * it is carried by the centre of its cameras (CameraCentreInRig): a
//    KITTI-360 rig's cameras sit 1.6 m ahead of its origin, so a rig that
//    followed the centre line by its origin swung them through the wall at
//    a corridor's corner;
//  * it is lowered where a camera would come within kCeilingClearanceM of
//    the ceiling anywhere on the route (the route's sway and bob
//    included): a rig built for a car roof (cameras 1.2 to 1.9 m above its
//    origin) carried through a 2.8 m corridor would otherwise put its
//    cameras in or above the ceiling, looking at the ceiling's back from a
//    few centimetres.
// Throws UsageError when the cameras span more height than the room leaves.
TrajectorySpec FitRigToRoom(const SceneWithRoute& world, const Rig& rig, const std::string& scene_name,
                            uint64_t seed) {
  TrajectorySpec spec = RouteTrajectorySpec(world, seed);
  if (!(world.ceiling_height_m > 0.0)) return spec;
  spec.route_point_in_rig = CameraCentreInRig(rig);
  const SmoothTrajectory trajectory(spec);
  double lowest = std::numeric_limits<double>::infinity();
  double highest = -lowest;
  const int64_t step_ns = 50'000'000;  // 20 Hz: finer than the sway and bob
  for (int64_t t_ns = 0; t_ns <= trajectory.DurationNs(); t_ns += step_ns) {
    const Rigid3d world_from_rig = trajectory.WorldFromRig(t_ns);
    for (const Camera& camera : rig.cameras) {
      const double z = (world_from_rig * camera.cam_from_rig.Inverse()).translation.z();
      lowest = std::min(lowest, z);
      highest = std::max(highest, z);
    }
  }
  const double top = world.ceiling_height_m - kCeilingClearanceM;
  if (highest > top) {
    const double drop = highest - top;
    if (lowest - drop < kFloorClearanceM) {
      throw UsageError(StrCat("the rig's cameras span ", FormatFixed(highest - lowest, 2),
                              " m in height on scene '", scene_name, "', more than its ",
                              FormatFixed(world.ceiling_height_m, 2), " m ceiling leaves (",
                              FormatFixed(kFloorClearanceM, 2), " m above the floor, ",
                              FormatFixed(kCeilingClearanceM, 2), " m below the ceiling)"));
    }
    spec.rig_height_m -= drop;
  }
  return spec;
}

std::string MetaJson(const SynthOptions& options, const std::string& scene_name, const SceneWithRoute& scene,
                     const TrajectorySpec& spec, double route_length_m, const Rig& rig, int frames) {
  nlohmann::ordered_json j;
  j["generator"] = "mcvo synth";
  j["preset"] = options.preset;
  j["rig"] = options.preset.empty() ? options.rig_path.filename().string() : "preset:" + options.preset;
  j["scene"] = scene_name;
  j["seed"] = options.seed;
  j["frames"] = frames;
  j["frame_rate_hz"] = options.frame_rate_hz;
  j["first_t_ns"] = options.first_t_ns;
  j["image_scale"] = options.image_scale;
  j["route_length_m"] = route_length_m;
  j["route_closed"] = scene.route_closed;
  j["rig_height_m"] = spec.rig_height_m;
  j["route_point_in_rig_m"] = {spec.route_point_in_rig.x(), spec.route_point_in_rig.y()};
  j["samples_per_axis"] = options.render.samples_per_axis;
  const RenderEffects& e = options.render.effects;
  j["effects"] = {
      {"noise_sigma", e.noise_sigma},
      {"exposure_changes", e.exposure_changes},
      {"vignetting", e.vignetting},
      {"motion_blur_samples", e.motion_blur_samples},
      {"exposure_time_s", e.exposure_time_s},
      {"moving_objects", scene.scene.moving_objects().size()},
      {"blackout_camera", e.blackout_camera == RenderEffects::kBlackoutAllCameras ? std::string("all")
                          : e.blackout_camera < 0                                 ? std::string()
                                                  : rig.cameras[e.blackout_camera].name},
      {"blackout_first_frame", e.blackout_first_frame},
      {"blackout_num_frames", e.blackout_num_frames}};
  // The realism effects only when set, so that meta.json stays as it was without them.
  if (e.HasSensorNoise()) j["effects"]["sensor_noise"] = {{"a", e.sensor_noise_a}, {"b", e.sensor_noise_b}};
  if (e.lens_blur_sigma_px > 0.0) j["effects"]["lens_blur_sigma_px"] = e.lens_blur_sigma_px;
  if (e.HasToneCurve()) j["effects"]["tone"] = {{"gain", e.tone_gain}, {"gamma", e.tone_gamma}};
  if (!options.stops.Empty()) {
    nlohmann::ordered_json stops = nlohmann::ordered_json::array();
    for (const Stop& stop : options.stops.stops)
      stops.push_back({{"at_s", stop.at_s}, {"duration_s", stop.duration_s}});
    j["standing"] = {{"stand_s", options.stops.stand_s}, {"ramp_s", options.stops.ramp_s}, {"stops", stops}};
  }
  nlohmann::ordered_json cameras = nlohmann::ordered_json::array();
  for (const Camera& camera : rig.cameras) cameras.push_back(camera.name);
  j["cameras"] = cameras;
  return j.dump(2) + "\n";
}

}  // namespace

const std::vector<SynthPreset>& SynthPresets() {
  static const std::vector<SynthPreset> presets = {
      {"irregular5", "irregular5", "urban",
       "5 cameras at odd angles and offsets, two fisheye (Kannala-Brandt, double sphere)"},
      {"kitti360", "kitti360", "urban",
       "the real KITTI-360 rig: 2 rectified pinhole 1408x376 + 2 MEI fisheye 1400x1400"},
      {"kitti360-3cam", "kitti360_3cam", "urban",
       "KITTI-360 image_00 + both fisheyes (the paper's 3-camera setup: no stereo overlap; the >180 deg "
       "fisheyes share only their image rims)"},
      {"mono", "kitti360_mono", "urban",
       "one camera: KITTI-360 image_00 alone (monocular odometry, arbitrary scale)"},
      {"multicam6", "multicam6", "indoor", "MultiCamData-like: 4 forward + 2 side 720x540 cameras"},
      {"stereo", "kitti360_stereo", "urban", "KITTI-360 rectified stereo pair image_00 + image_01"},
  };
  return presets;
}

const SynthPreset& FindPreset(const std::string& preset_name) {
  std::string known;
  for (const SynthPreset& preset : SynthPresets()) {
    if (preset.name == preset_name) return preset;
    known += (known.empty() ? "" : ", ") + preset.name;
  }
  MCVO_THROW_INPUT("unknown preset '", preset_name, "' (known: ", known, ")");
}

Rig PresetRig(const std::string& preset_name) {
  const SynthPreset& preset = FindPreset(preset_name);
  for (const auto& [name, text] : internal::EmbeddedRigFiles()) {
    if (name == preset.rig_file) {
      return ParseRigJson(std::string(text), "config/rigs/" + preset.rig_file + ".json (compiled in)", "");
    }
  }
  MCVO_CHECK_MSG(false, "preset rig file not compiled in: ", preset.rig_file);
  return {};
}

void SynthOptions::Check() const {
  if (preset.empty() == rig_path.empty()) throw UsageError("give either --preset or --rig");
  if (!rig_path.empty() && scene.empty()) {
    std::string known;
    for (const std::string& name : SceneNames()) known += (known.empty() ? "" : ", ") + name;
    throw UsageError("--rig needs --scene (" + known + ")");
  }
  if (frames < 0) throw UsageError(StrCat("frames: must be >= 0, got ", frames));
  if (!(laps >= 0.0 && laps <= 1e4))
    throw UsageError(StrCat("laps: must be in [0, 1e4], got ", FormatDouble(laps)));
  if (laps > 0.0 && frames > 0) throw UsageError("give either frames or laps, not both");
  if (!(image_scale > 0.0 && image_scale <= 4.0)) {
    throw UsageError(StrCat("image_scale: must be in (0, 4], got ", FormatDouble(image_scale)));
  }
  if (!(frame_rate_hz > 0.0 && frame_rate_hz <= 1000.0)) {
    throw UsageError(StrCat("frame_rate_hz: must be in (0, 1000], got ", FormatDouble(frame_rate_hz)));
  }
  render.Check();
  stops.Check();
}

SynthSummary Synthesize(const SynthOptions& options, const std::filesystem::path& out_dir,
                        const std::function<void(int, int)>& progress) {
  options.Check();
  const std::string scene_name = options.scene.empty() ? FindPreset(options.preset).scene : options.scene;
  Rig rig = ResolveRig(options);
  if (options.render.effects.blackout_camera >= rig.NumCameras()) {
    throw UsageError(StrCat("blackout camera index ", options.render.effects.blackout_camera,
                            " but the rig has ", rig.NumCameras(), " cameras"));
  }
  const SceneWithRoute world = BuildScene(scene_name, options.seed);
  const TrajectorySpec spec = FitRigToRoom(world, rig, scene_name, options.seed);
  const SmoothTrajectory trajectory(spec);
  const double period_s = 1.0 / options.frame_rate_hz;
  const int64_t period_ns = std::llround(period_s * 1e9);
  if (options.laps > 1.0 && !world.route_closed) {
    throw UsageError(StrCat("laps: the route of scene '", scene_name,
                            "' is open and can be driven once (laps <= 1), got ",
                            FormatDouble(options.laps)));
  }
  const double laps = options.laps > 0.0 ? options.laps : 1.0;
  // Standing adds to the time of a lap: the stand, each stop, half of each ramp.
  double standing_ns = 0.0;
  if (!options.stops.Empty()) {
    const StopPlan& plan = options.stops;
    standing_ns = 1e9 * (plan.stand_s > 0.0 ? plan.stand_s + 0.5 * plan.ramp_s : 0.0);
    for (const Stop& stop : plan.stops) standing_ns += 1e9 * (stop.duration_s + plan.ramp_s);
  }
  const double frames_in_laps = std::floor(
      (laps * static_cast<double>(trajectory.DurationNs()) + standing_ns) / static_cast<double>(period_ns));
  if (options.frames == 0 && frames_in_laps > 1e7) {
    throw UsageError(StrCat("laps: ", FormatDouble(laps), " laps are ", FormatDouble(frames_in_laps),
                            " frames, more than 1e7"));
  }
  const int frames = options.frames > 0 ? options.frames : std::max(1, static_cast<int>(frames_in_laps));

  // Everything is written below the staging folder and moved onto out_dir
  // at the end (util/output_folder.h).
  OutputFolderOptions out_options;
  out_options.force = options.force;
  out_options.kind = "synth";
  if (!options.rig_path.empty()) out_options.inputs.push_back(options.rig_path);
  OutputFolder out(out_dir, out_options);
  CreateDirectories(out.staging() / "structure");

  FrameTable table;
  for (Camera& camera : rig.cameras) {
    table.camera_names.push_back(camera.name);
    CreateDirectories(out.staging() / "images" / camera.name);
    const cv::Mat mask = ValidPixelMask(camera);
    if (!mask.empty()) {
      CreateDirectories(out.staging() / "masks");
      camera.mask_path = (out.staging() / "masks" / (camera.name + ".png")).string();
      WritePng(camera.mask_path, mask);
    }
  }

  SynthSummary summary;
  summary.cameras = rig.NumCameras();
  summary.frames = frames;
  summary.route_length_m = trajectory.LengthM();
  summary.route_closed = world.route_closed;
  summary.lap_seconds = static_cast<double>(trajectory.DurationNs()) * 1e-9;
  summary.laps = static_cast<double>(frames) * static_cast<double>(period_ns) /
                 static_cast<double>(trajectory.DurationNs());
  for (const Camera& camera : rig.cameras)
    summary.megapixels_per_frame += camera.width * camera.height * 1e-6;

  // Route time of a sequence instant (stops.h); the identity without stops.
  const auto world_from_rig = [&](int64_t t_ns) {
    if (options.stops.Empty()) return trajectory.WorldFromRig(t_ns);
    return trajectory.WorldFromRig(
        std::llround(options.stops.RouteSeconds(static_cast<double>(t_ns) * 1e-9) * 1e9));
  };
  std::vector<int64_t> times_ns(static_cast<size_t>(frames));
  for (int frame = 0; frame < frames; ++frame) times_ns[static_cast<size_t>(frame)] = frame * period_ns;
  CheckCamerasInRoom(world, spec, rig, scene_name, world_from_rig, times_ns, period_s);
  Trajectory ground_truth;
  ground_truth.has_time = true;
  const auto start = std::chrono::steady_clock::now();
  for (int frame = 0; frame < frames; ++frame) {
    const int64_t t_rel_ns = static_cast<int64_t>(frame) * period_ns;
    FrameTableRow row;
    row.t_ns = options.first_t_ns + t_rel_ns;
    for (int c = 0; c < rig.NumCameras(); ++c) {
      const ScopedStage stage(StrCat("synth: rendering frame ", frame, " of camera ", rig.cameras[c].name));
      const cv::Mat image = RenderImage(world.scene, rig, c, world_from_rig, t_rel_ns, frame, options.render);
      const std::string relative = "images/" + rig.cameras[c].name + "/" + FrameFileName(frame);
      WritePng(out.staging() / relative, image);
      row.image_paths.push_back(relative);
    }
    table.rows.push_back(std::move(row));
    StampedPose pose;
    pose.t_ns = options.first_t_ns + t_rel_ns;
    pose.frame_index = frame;
    pose.world_from_body = world_from_rig(t_rel_ns);
    ground_truth.poses.push_back(pose);
    if (progress) progress(frame + 1, frames);
    ThrowIfCancelled();
  }
  summary.render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  WriteRig(out.staging() / "rig.json", rig);
  WriteFrameTable(out.staging() / "frames.csv", table);
  WriteTrajectory(out.staging() / "groundtruth.tum", ground_truth, TrajectoryFormat::kTum);
  WriteSceneCsv(out.staging() / "structure" / "scene_quads.csv", world.scene);
  WriteFileAtomic(out.staging() / "meta.json",
                  MetaJson(options, scene_name, world, spec, trajectory.LengthM(), rig, frames));

  ThrowIfCancelled();
  out.Commit();
  return summary;
}

}  // namespace mcvo::synth
