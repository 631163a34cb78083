// WriteColmapModel: a run's SparseMap as a COLMAP workspace. The model is
// built in memory (ids, names, observations, tracks, errors), then the
// images are linked, copied or remapped and sampled for colours (in
// parallel, into per-image slots), then everything is written into a staging
// folder that is renamed onto out_dir.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <exception>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "colmap_internal.h"
#include "mcvo/colmap/colmap_model.h"
#include "mcvo/dataset/image_container.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/option_checks.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

// One (keyframe, camera) image while the model is built.
struct PendingImage {
  uint32_t id = 0;
  int keyframe = 0;
  int frame_index = 0;  // the keyframe's
  int camera = 0;
  std::string name;
  fs::path source;  // the dataset's file, empty when the keyframe lists none
  Rigid3d cam_from_world;
  // Observations, in the keyframe's order: the written 2-D point (COLMAP
  // convention), the pixel in the source image (OpenCV convention, for
  // colours) and the landmark's index in SparseMap::landmarks.
  std::vector<Eigen::Vector2d> points2d;
  std::vector<Eigen::Vector2d> source_pixels;
  std::vector<int> landmarks;
};

// What the image pass found for one image.
struct ImageResult {
  bool written = false;
  bool read_for_color = false;
  std::vector<Eigen::Vector3d> colors;  // per observation, RGB in [0, 255]
  std::vector<bool> has_color;
  std::exception_ptr error;
};

// The same rotation with qw >= 0 (q and -q are the same rotation): one
// canonical text for a pose.
Rigid3d Canonical(const Rigid3d& pose) {
  Rigid3d out = pose;
  if (out.rotation.w() < 0.0) out.rotation.coeffs() = -out.rotation.coeffs();
  return out;
}

std::string Padded(int value) {
  std::ostringstream out;
  out << std::setw(6) << std::setfill('0') << value;
  return out.str();
}

// Checks that the map refers to the rig's cameras and to its own landmarks.
void CheckMap(const Rig& rig, const SparseMap& map) {
  for (size_t i = 1; i < map.landmarks.size(); ++i) {
    if (!(map.landmarks[i - 1].id < map.landmarks[i].id))
      MCVO_THROW_INPUT("sparse map: landmarks[", i, "]: ids must be strictly ascending (",
                       map.landmarks[i - 1].id, " then ", map.landmarks[i].id, ")");
  }
  // point3D_id = landmark id + 1 must stay a positive int64 (COLMAP reads it with stoll).
  if (!map.landmarks.empty() && map.landmarks.front().id < 0)
    MCVO_THROW_INPUT("sparse map: landmark id ", map.landmarks.front().id, " is negative");
  if (!map.landmarks.empty() && map.landmarks.back().id == std::numeric_limits<int64_t>::max())
    MCVO_THROW_INPUT("sparse map: landmark id ", map.landmarks.back().id, " is too large for COLMAP");
  for (size_t i = 0; i < map.landmarks.size(); ++i) {
    if (!map.landmarks[i].position_world.allFinite())
      MCVO_THROW_INPUT("sparse map: landmark ", map.landmarks[i].id, ": position is not finite");
  }
  for (size_t k = 0; k < map.keyframes.size(); ++k) {
    const MapKeyframe& keyframe = map.keyframes[k];
    const std::string where = StrCat("sparse map: keyframes[", k, "] (frame ", keyframe.frame_index, ")");
    if (!keyframe.images.empty() && static_cast<int>(keyframe.images.size()) != rig.NumCameras())
      MCVO_THROW_INPUT(where, ": ", keyframe.images.size(), " image paths for ", rig.NumCameras(),
                       " cameras");
    if (!keyframe.world_from_rig.translation.allFinite() ||
        !keyframe.world_from_rig.rotation.coeffs().allFinite())
      MCVO_THROW_INPUT(where, ": pose is not finite");
    std::vector<std::pair<int, int64_t>> seen;
    seen.reserve(keyframe.observations.size());
    for (const MapObservation& observation : keyframe.observations) {
      if (observation.camera < 0 || observation.camera >= rig.NumCameras())
        MCVO_THROW_INPUT(where, ": observation of camera ", observation.camera, ", the rig has ",
                         rig.NumCameras());
      if (!observation.pixel.allFinite())
        MCVO_THROW_INPUT(where, ": observation of landmark ", observation.landmark_id,
                         ": pixel is not finite");
      seen.emplace_back(observation.camera, observation.landmark_id);
    }
    std::sort(seen.begin(), seen.end());
    for (size_t i = 1; i < seen.size(); ++i) {
      if (seen[i] == seen[i - 1])
        MCVO_THROW_INPUT(where, ": landmark ", seen[i].second, " observed twice by camera ", seen[i].first);
    }
  }
}

// Index of the landmark with this id in map.landmarks (ascending ids), or -1.
int FindLandmark(const SparseMap& map, int64_t id) {
  const auto it = std::lower_bound(map.landmarks.begin(), map.landmarks.end(), id,
                                   [](const MapLandmark& landmark, int64_t v) { return landmark.id < v; });
  return it != map.landmarks.end() && it->id == id ? static_cast<int>(it - map.landmarks.begin()) : -1;
}

// The name of a keyframe image in the model: its path below dataset_root
// when it lies there, else "<camera>/<file name>". Blanks (which COLMAP's
// text format cannot hold) become '_'.
std::string BaseImageName(const fs::path& listed, const fs::path& dataset_root,
                          const std::string& camera_name) {
  fs::path relative;
  if (listed.is_relative()) {
    relative = listed.lexically_normal();
  } else if (!dataset_root.empty()) {
    relative = listed.lexically_normal().lexically_relative(fs::absolute(dataset_root).lexically_normal());
  }
  const bool below_root = !relative.empty() && *relative.begin() != ".." && *relative.begin() != ".";
  std::string name = below_root ? relative.generic_string() : camera_name + "/" + listed.filename().string();
  return name;
}

bool ReplaceBlanks(std::string* name) {
  bool replaced = false;
  for (char& c : *name) {
    if (c == ' ' || c == '\t' || c == '\r' || c == '\n') {
      c = '_';
      replaced = true;
    }
  }
  return replaced;
}

void WriteImage(const fs::path& path, const cv::Mat& image) {
  // Fixed encoder settings: the same pixels always give the same bytes.
  std::vector<int> params;
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".png") params = {cv::IMWRITE_PNG_COMPRESSION, 3};
  if (extension == ".jpg" || extension == ".jpeg") params = {cv::IMWRITE_JPEG_QUALITY, 95};
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), image, params);
  } catch (const cv::Exception& e) {
    MCVO_THROW_INPUT(path.string(), ": cannot write the image: ", e.what());
  }
  if (!ok) MCVO_THROW_INPUT(path.string(), ": cannot write the image");
}

// The colours of every observation of `image` from `samples`; false (result
// untouched) when a pixel is missing there.
bool ColorsFromSamples(const PendingImage& image, const ColmapColorSamples& samples, ImageResult* result) {
  std::vector<int> index(image.source_pixels.size());
  for (size_t i = 0; i < index.size(); ++i) {
    index[i] = samples.Find(image.source_pixels[i]);
    if (index[i] < 0) return false;
  }
  result->read_for_color = true;
  result->colors.assign(index.size(), Eigen::Vector3d::Zero());
  result->has_color.assign(index.size(), false);
  for (size_t i = 0; i < index.size(); ++i) {
    const size_t at = static_cast<size_t>(index[i]);
    result->has_color[i] = samples.has_color[at];
    result->colors[i] = samples.colors[at];
  }
  return true;
}

// Links, copies or remaps one image into images/ and samples its colours;
// samples: colours sampled ahead (WriteColmapModel's table), or null.
void ProcessImage(const PendingImage& image, const ColmapCameraExport& camera_export, const cv::Mat* map_x,
                  const cv::Mat* map_y, const ColmapExportOptions& options, const fs::path& image_dir,
                  const ColmapColorSamples* samples, ImageResult* result) {
  const std::string where = StrCat(" (image '", image.name, "', camera '", camera_export.name, "')");
  const bool write = options.image_mode != ColmapImageMode::kNone;
  std::error_code ec;
  // A ROS bag's image has no file to link or copy: decoded and written (PNG).
  const bool in_container = !ImageContainerFile(image.source).empty();
  if (write && !in_container && !fs::is_regular_file(image.source, ec))
    MCVO_THROW_INPUT(image.source.string(), ": image not found", where);
  // Decoded only to remap it, or for colours the table does not have.
  const bool colors_given = options.sample_colors && samples != nullptr && !camera_export.undistorted &&
                            ColorsFromSamples(image, *samples, result);
  cv::Mat decoded;
  if (camera_export.undistorted || (options.sample_colors && !colors_given) || (write && in_container))
    decoded = DecodeColmapColorImage(image.source);
  const fs::path target = image_dir / image.name;
  if (write) {
    if (camera_export.undistorted) {
      if (decoded.empty()) MCVO_THROW_INPUT(image.source.string(), ": cannot decode the image", where);
      cv::Mat remapped;
      cv::remap(decoded, remapped, *map_x, *map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
      WriteImage(target, remapped);
    } else if (in_container) {
      if (decoded.empty()) MCVO_THROW_INPUT(image.source.string(), ": cannot decode the image", where);
      WriteImage(target, decoded);
    } else if (options.image_mode == ColmapImageMode::kLink) {
      fs::create_symlink(fs::absolute(image.source).lexically_normal(), target, ec);
      if (ec) MCVO_THROW_INPUT(target.string(), ": cannot create the link: ", ec.message());
    } else {
      fs::copy_file(image.source, target, fs::copy_options::overwrite_existing, ec);
      if (ec) MCVO_THROW_INPUT(target.string(), ": cannot copy ", image.source.string(), ": ", ec.message());
    }
    result->written = true;
  }
  if (options.sample_colors && !colors_given && !decoded.empty()) {
    result->read_for_color = true;
    const cv::Mat bgr = colmap_internal::ToBgr8(decoded);
    result->colors.assign(image.source_pixels.size(), Eigen::Vector3d::Zero());
    result->has_color.assign(image.source_pixels.size(), false);
    for (size_t i = 0; i < image.source_pixels.size(); ++i)
      result->has_color[i] = colmap_internal::SampleBilinear(bgr, image.source_pixels[i], &result->colors[i]);
  }
}

// Rig and frames (COLMAP 3.12): the rig frame of COLMAP is its reference
// sensor's (camera 1), so sensor_from_rig = cam_from_rig * rig_from_cam1 and
// a frame's pose is cam1_from_world; one frame per keyframe with images.
void AddRigAndFrames(const Rig& rig, const SparseMap& map, const std::vector<PendingImage>& images,
                     ColmapModel* model) {
  const Rigid3d cam1_from_rig = rig.cameras[0].cam_from_rig;
  const Rigid3d rig_from_cam1 = cam1_from_rig.Inverse();
  ColmapRig colmap_rig;
  colmap_rig.id = 1;
  colmap_rig.ref_camera_id = 1;
  for (int c = 1; c < rig.NumCameras(); ++c) {
    colmap_rig.sensors.push_back(
        {static_cast<uint32_t>(c + 1), Canonical(rig.cameras[c].cam_from_rig * rig_from_cam1)});
  }
  model->rigs.push_back(std::move(colmap_rig));
  for (const PendingImage& image : images) {
    if (model->frames.empty() || model->frames.back().id != static_cast<uint32_t>(image.keyframe + 1)) {
      ColmapFrame frame;
      frame.id = static_cast<uint32_t>(image.keyframe + 1);
      frame.rig_id = 1;
      frame.rig_from_world =
          Canonical(cam1_from_rig * map.keyframes[image.keyframe].world_from_rig.Inverse());
      model->frames.push_back(std::move(frame));
    }
    model->frames.back().data.push_back({static_cast<uint32_t>(image.camera + 1), image.id});
  }
}

// The report's per-camera totals and its notes.
void AddNotes(const ColmapExportOptions& options, bool blanks_replaced, ColmapExportReport* report) {
  for (const ColmapCameraExport& camera_export : report->camera_exports) {
    report->observations_dropped += camera_export.observations_dropped;
    const std::string head =
        StrCat("camera '", camera_export.name, "' (", CameraModelName(camera_export.source_model), ") -> ",
               ColmapCameraModelName(camera_export.camera.model));
    if (camera_export.fitted) {
      report->notes.push_back(StrCat(
          head, " fitted up to ", FormatFixed(camera_export.max_angle_deg, 1), " deg: RMS ",
          FormatFixed(camera_export.fit_rms_px, 3), " px, max ", FormatFixed(camera_export.fit_max_px, 3),
          " px over ", camera_export.fit_samples, " samples; ", camera_export.observations_dropped,
          " observations beyond the fitted angle dropped"));
    } else if (camera_export.undistorted) {
      report->notes.push_back(StrCat(head, " ", camera_export.camera.width, "x", camera_export.camera.height,
                                     ", field of view ", FormatFixed(camera_export.fov_x_deg, 1), " x ",
                                     FormatFixed(camera_export.fov_y_deg, 1), " deg; images remapped; ",
                                     camera_export.observations_dropped, " observations outside it dropped"));
    } else if (camera_export.observations_dropped > 0) {
      report->notes.push_back(StrCat(
          head, ": ", camera_export.observations_dropped,
          " observations COLMAP cannot express (point or pixel at or beyond 90 deg from the axis) dropped"));
    }
  }
  if (report->landmarks_dropped > 0) {
    report->notes.push_back(StrCat(report->landmarks_dropped, " landmarks with fewer than ",
                                   options.min_track_length, " observations not written"));
  }
  if (report->images_without_source > 0) {
    report->notes.push_back(StrCat(report->images_without_source,
                                   " images have no dataset image (placeholder names <camera>/<frame>.png)"));
  }
  if (report->images_without_color > 0) {
    report->notes.push_back(StrCat(report->images_without_color,
                                   " images could not be read for colours (their points may be grey)"));
  }
  if (blanks_replaced)
    report->notes.push_back("blanks in image names replaced by '_' (COLMAP's text format)");
}

// The rig's cameras as COLMAP cameras (fitted or undistorted per
// fisheye_policy) into report->camera_exports; the undistortion maps of the
// undistorted ones when images are written.
void ConvertCameras(const Rig& rig, const ColmapExportOptions& options, ColmapExportReport* report,
                    std::vector<cv::Mat>* maps_x, std::vector<cv::Mat>* maps_y) {
  maps_x->assign(static_cast<size_t>(rig.NumCameras()), cv::Mat());
  maps_y->assign(static_cast<size_t>(rig.NumCameras()), cv::Mat());
  for (int c = 0; c < rig.NumCameras(); ++c) {
    report->camera_exports.push_back(
        ConvertCameraToColmap(rig.cameras[c], static_cast<uint32_t>(c + 1), options));
    if (report->camera_exports.back().undistorted && options.image_mode == ColmapImageMode::kNone) {
      throw UsageError(StrCat("colmap export: camera '", rig.cameras[c].name,
                              "' is undistorted (fisheye_policy undistort), which needs its images written: "
                              "image_mode must be link or copy"));
    }
  }
  if (options.image_mode != ColmapImageMode::kNone) {
    for (int c = 0; c < rig.NumCameras(); ++c) {
      if (report->camera_exports[c].undistorted)
        colmap_internal::MakeUndistortMaps(rig.cameras[c], report->camera_exports[c].camera, &(*maps_x)[c],
                                           &(*maps_y)[c]);
    }
  }
}

// Images, in keyframe then camera order, with their kept observations (in
// front of the camera, inside the exported model's domain);
// (*track_length)[l]: observations of landmark l kept.
std::vector<PendingImage> CollectImages(const Rig& rig, const SparseMap& map, const fs::path& dataset_root,
                                        ColmapExportReport* report, std::vector<int>* track_length,
                                        bool* blanks_replaced) {
  std::vector<PendingImage> images;
  std::map<std::string, size_t> names;
  *blanks_replaced = false;
  track_length->assign(map.landmarks.size(), 0);
  for (size_t k = 0; k < map.keyframes.size(); ++k) {
    const MapKeyframe& keyframe = map.keyframes[k];
    const Rigid3d rig_from_world = keyframe.world_from_rig.Inverse();
    for (int c = 0; c < rig.NumCameras(); ++c) {
      const fs::path listed = keyframe.images.empty() ? fs::path() : keyframe.images[c];
      PendingImage image;
      image.keyframe = static_cast<int>(k);
      image.frame_index = keyframe.frame_index;
      image.camera = c;
      image.cam_from_world = Canonical(rig.cameras[c].cam_from_rig * rig_from_world);
      const Camera& camera = rig.cameras[c];
      ColmapCameraExport& camera_export = report->camera_exports[c];
      bool has_observations = false;
      for (const MapObservation& observation : keyframe.observations) {
        if (observation.camera != c) continue;
        has_observations = true;
        const int landmark = FindLandmark(map, observation.landmark_id);
        if (landmark < 0) {
          MCVO_THROW_INPUT("sparse map: keyframes[", k, "] (frame ", keyframe.frame_index, "): landmark ",
                           observation.landmark_id, " is not in the map's landmarks");
        }
        const Eigen::Vector3d point_in_cam = image.cam_from_world * map.landmarks[landmark].position_world;
        std::optional<Eigen::Vector2d> point2d;
        if (point_in_cam.z() >= DBL_EPSILON) {  // COLMAP projects nothing else
          if (camera_export.undistorted) {
            point2d = colmap_internal::UndistortPixel(camera, camera_export.camera, observation.pixel);
          } else if (const std::optional<Eigen::Vector3d> bearing = camera.Unproject(observation.pixel);
                     bearing && bearing->z() > 0.0 &&
                     colmap_internal::AngleFromAxisDeg(*bearing) <= camera_export.max_angle_deg) {
            point2d = observation.pixel + Eigen::Vector2d(0.5, 0.5);
          }
        }
        if (!point2d) {
          ++camera_export.observations_dropped;
          continue;
        }
        image.points2d.push_back(*point2d);
        image.source_pixels.push_back(observation.pixel);
        image.landmarks.push_back(landmark);
        ++(*track_length)[landmark];
      }
      if (listed.empty() && !has_observations) continue;
      if (listed.empty()) {
        ++report->images_without_source;
        image.name = camera.name + "/" + Padded(keyframe.frame_index) + ".png";
      } else {
        image.source = listed.is_absolute() ? listed : dataset_root / listed;
        image.name = BaseImageName(listed, dataset_root, camera.name);
        // A ROS bag's image (a member of the bag file, image_container.h) is written out as PNG.
        if (!ImageContainerFile(image.source).empty()) image.name += ".png";
      }
      *blanks_replaced |= ReplaceBlanks(&image.name);
      if (names.count(image.name) != 0) {
        // Two files of the same name outside dataset_root: prefix the frame index.
        const std::string alternative =
            camera.name + "/" + Padded(keyframe.frame_index) + "_" + fs::path(image.name).filename().string();
        if (names.count(alternative) != 0) {
          MCVO_THROW_INPUT("sparse map: keyframes[", k, "] (frame ", keyframe.frame_index, "): image name '",
                           image.name, "' of camera '", camera.name, "' is not unique");
        }
        image.name = alternative;
      }
      image.id = static_cast<uint32_t>(images.size() + 1);
      names.emplace(image.name, images.size());
      images.push_back(std::move(image));
    }
  }
  return images;
}

// The model's points (landmarks with at least min_track_length kept
// observations), its images with the observations of those points only
// (dropped from `images` too), its cameras; *point_index_of_landmark maps a
// landmark to its point (kColmapNoPoint3D: none); *error_total sums the
// points' mean reprojection errors.
ColmapModel BuildModel(const SparseMap& map, const ColmapExportOptions& options,
                       const std::vector<int>& track_length, std::vector<PendingImage>* images_io,
                       ColmapExportReport* report, std::vector<uint64_t>* point_index_of_landmark,
                       double* error_total_out) {
  std::vector<PendingImage>& images = *images_io;
  ColmapModel model;
  point_index_of_landmark->assign(map.landmarks.size(), kColmapNoPoint3D);
  for (size_t l = 0; l < map.landmarks.size(); ++l) {
    if (track_length[l] >= options.min_track_length) {
      (*point_index_of_landmark)[l] = model.points3d.size();
      ColmapPoint3D point;
      point.id = static_cast<uint64_t>(map.landmarks[l].id) + 1;
      point.xyz = map.landmarks[l].position_world;
      model.points3d.push_back(point);
    } else {
      ++report->landmarks_dropped;
    }
  }
  for (PendingImage& image : images) {
    // Drop the observations of landmarks that did not become points.
    size_t kept = 0;
    for (size_t i = 0; i < image.landmarks.size(); ++i) {
      if ((*point_index_of_landmark)[image.landmarks[i]] == kColmapNoPoint3D) continue;
      image.points2d[kept] = image.points2d[i];
      image.source_pixels[kept] = image.source_pixels[i];
      image.landmarks[kept] = image.landmarks[i];
      ++kept;
    }
    image.points2d.resize(kept);
    image.source_pixels.resize(kept);
    image.landmarks.resize(kept);
    report->camera_exports[image.camera].observations_written += static_cast<int64_t>(kept);
  }
  std::vector<double> error_sum(model.points3d.size(), 0.0);
  for (const PendingImage& image : images) {
    const ColmapCamera& camera = report->camera_exports[image.camera].camera;
    ColmapImage out;
    out.id = image.id;
    out.cam_from_world = image.cam_from_world;
    out.camera_id = camera.id;
    out.name = image.name;
    out.points2d = image.points2d;
    for (size_t i = 0; i < image.landmarks.size(); ++i) {
      const uint64_t p = (*point_index_of_landmark)[image.landmarks[i]];
      ColmapPoint3D& point = model.points3d[p];
      out.point3d_ids.push_back(point.id);
      point.track.push_back({image.id, static_cast<uint32_t>(i)});
      const std::optional<Eigen::Vector2d> projected =
          ColmapProject(camera, image.cam_from_world * point.xyz);
      MCVO_CHECK(projected.has_value());  // only points in front were kept
      error_sum[p] += (*projected - image.points2d[i]).norm();
    }
    model.images.push_back(std::move(out));
  }
  double& error_total = *error_total_out;
  error_total = 0.0;
  for (size_t p = 0; p < model.points3d.size(); ++p) {
    model.points3d[p].error = error_sum[p] / static_cast<double>(model.points3d[p].track.size());
    error_total += model.points3d[p].error;
  }
  for (const ColmapCameraExport& camera_export : report->camera_exports)
    model.cameras.push_back(camera_export.camera);
  return model;
}

// Images linked, copied or remapped into image_dir and the points' colours
// sampled, in parallel into slots; report's image counts.
void ExportImages(const std::vector<PendingImage>& images, const std::vector<cv::Mat>& maps_x,
                  const std::vector<cv::Mat>& maps_y, const ColmapExportOptions& options,
                  const fs::path& image_dir, const std::vector<uint64_t>& point_index_of_landmark,
                  const ColmapColorTable* colors, ColmapExportReport* report, ColmapModel* model) {
  if (options.image_mode != ColmapImageMode::kNone) {
    for (const PendingImage& image : images) {
      if (!image.source.empty()) CreateDirectories((image_dir / image.name).parent_path());
    }
  }
  std::vector<ImageResult> results(images.size());
  const int threads = ResolveThreads(options.threads);
  const bool image_pass = options.image_mode != ColmapImageMode::kNone || options.sample_colors;
  if (image_pass) {
    ParallelFor(static_cast<int>(images.size()), threads, [&](int i) {
      const PendingImage& image = images[i];
      if (image.source.empty()) return;
      const ColmapColorSamples* samples = nullptr;
      if (colors != nullptr) {
        const auto it = colors->find({image.frame_index, image.camera});
        if (it != colors->end()) samples = &it->second;
      }
      try {
        ProcessImage(image, report->camera_exports[image.camera], &maps_x[image.camera],
                     &maps_y[image.camera], options, image_dir, samples, &results[i]);
      } catch (...) {
        results[i].error = std::current_exception();
      }
    });
  }
  std::vector<Eigen::Vector3d> color_sum(model->points3d.size(), Eigen::Vector3d::Zero());
  std::vector<int> color_count(model->points3d.size(), 0);
  for (size_t i = 0; i < images.size(); ++i) {
    if (results[i].error) std::rethrow_exception(results[i].error);
    report->images_written += results[i].written ? 1 : 0;
    if (options.sample_colors && !images[i].source.empty() && !results[i].read_for_color)
      ++report->images_without_color;
    for (size_t o = 0; o < results[i].colors.size(); ++o) {
      if (!results[i].has_color[o]) continue;
      const uint64_t p = point_index_of_landmark[images[i].landmarks[o]];
      color_sum[p] += results[i].colors[o];
      ++color_count[p];
    }
  }
  for (size_t p = 0; p < model->points3d.size(); ++p) {
    for (int c = 0; c < 3; ++c) {
      model->points3d[p].rgb[c] =
          color_count[p] == 0
              ? 128
              : static_cast<uint8_t>(std::clamp(std::lround(color_sum[p][c] / color_count[p]), 0L, 255L));
    }
  }
}

}  // namespace

void ColmapExportOptions::Check() const {
  CheckInRange("/colmap/fisheye_max_angle_deg", fisheye_max_angle_deg, 1.0, 89.0);
  CheckAtLeast("/colmap/fit_grid", fit_grid, 8);
  if (fit_grid > 1024) MCVO_THROW_INPUT("/colmap/fit_grid: must be <= 1024, got ", fit_grid);
  CheckInRange("/colmap/undistort_fov_deg", undistort_fov_deg, 10.0, 170.0);
  CheckAtLeast("/colmap/min_track_length", min_track_length, 1);
  CheckAtLeast("/colmap/threads", threads, 0);
}

ColmapExportReport WriteColmapModel(const Rig& rig, const SparseMap& map, const fs::path& dataset_root,
                                    const ColmapExportOptions& options, const fs::path& out_dir,
                                    const ColmapColorTable* colors) {
  options.Check();
  if (rig.NumCameras() == 0) MCVO_THROW_INPUT("rig: no cameras");
  CheckMap(rig, map);
  const fs::path absolute_out = fs::absolute(out_dir).lexically_normal();
  std::error_code ec;
  if (fs::exists(absolute_out, ec)) {
    if (!fs::is_directory(absolute_out, ec))
      MCVO_THROW_INPUT(absolute_out.string(), ": exists and is not a folder");
    if (!fs::is_empty(absolute_out, ec) && !options.overwrite)
      MCVO_THROW_INPUT(absolute_out.string(),
                       ": folder exists and is not empty (set overwrite to replace it)");
  }

  ColmapExportReport report;
  std::vector<cv::Mat> maps_x, maps_y;
  ConvertCameras(rig, options, &report, &maps_x, &maps_y);

  bool blanks_replaced = false;
  std::vector<int> track_length;
  std::vector<PendingImage> images =
      CollectImages(rig, map, dataset_root, &report, &track_length, &blanks_replaced);

  std::vector<uint64_t> point_index_of_landmark;
  double error_total = 0.0;
  ColmapModel model =
      BuildModel(map, options, track_length, &images, &report, &point_index_of_landmark, &error_total);

  if (options.write_rig_files) AddRigAndFrames(rig, map, images, &model);

  // Staging folder, renamed onto out_dir at the end.
  CreateDirectories(absolute_out.parent_path());
  TemporaryFolder staging(absolute_out.parent_path() /
                          (absolute_out.filename().string() + ".tmp-" + std::to_string(::getpid())));
  fs::remove_all(staging.path(), ec);
  CreateDirectories(staging.path());
  const fs::path image_dir = staging.path() / "images";

  ExportImages(images, maps_x, maps_y, options, image_dir, point_index_of_landmark, colors, &report, &model);

  // Model files.
  const fs::path model_dir = staging.path() / "sparse" / "0";
  if (options.format != ColmapModelFormat::kText) WriteColmapModelBinary(model, model_dir);
  if (options.format == ColmapModelFormat::kText) WriteColmapModelText(model, model_dir);
  if (options.format == ColmapModelFormat::kBoth)
    WriteColmapModelText(model, staging.path() / "sparse_txt" / "0");

  if (fs::exists(absolute_out, ec)) fs::remove_all(absolute_out, ec);
  fs::rename(staging.path(), absolute_out, ec);
  if (ec)
    MCVO_THROW_INPUT(absolute_out.string(), ": cannot move the finished export into place: ", ec.message());
  staging.Release();

  // Report.
  report.model_dir = absolute_out / "sparse" / "0";
  if (options.format == ColmapModelFormat::kText) report.text_dir = report.model_dir;
  if (options.format == ColmapModelFormat::kBoth) report.text_dir = absolute_out / "sparse_txt" / "0";
  if (options.image_mode != ColmapImageMode::kNone) report.image_dir = absolute_out / "images";
  report.cameras = static_cast<int>(model.cameras.size());
  report.images = static_cast<int>(model.images.size());
  report.points = static_cast<int>(model.points3d.size());
  report.observations = model.NumObservations();
  report.mean_reprojection_error_px =
      model.points3d.empty() ? 0.0 : error_total / static_cast<double>(model.points3d.size());
  report.mean_track_length = model.points3d.empty() ? 0.0
                                                    : static_cast<double>(report.observations) /
                                                          static_cast<double>(model.points3d.size());
  AddNotes(options, blanks_replaced, &report);
  return report;
}

std::string DescribeColmapExport(const ColmapExportReport& report) {
  std::string out =
      StrCat("COLMAP model ", report.model_dir.string(), ": ", report.cameras, " cameras, ", report.images,
             " images, ", report.points, " points, ", report.observations,
             " observations, mean track length ", FormatFixed(report.mean_track_length, 2),
             ", mean reprojection error ", FormatFixed(report.mean_reprojection_error_px, 4), " px\n");
  if (!report.text_dir.empty() && report.text_dir != report.model_dir)
    out += StrCat("  text copy: ", report.text_dir.string(), "\n");
  if (!report.image_dir.empty())
    out += StrCat("  images: ", report.image_dir.string(), " (", report.images_written, " files)\n");
  for (const std::string& note : report.notes) out += "  " + note + "\n";
  return out;
}

}  // namespace mcvo
