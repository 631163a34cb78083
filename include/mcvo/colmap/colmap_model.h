// COLMAP sparse models: the in-memory model, its text and binary files
// (readers and writers), COLMAP's projection, and the export of a run's
// SparseMap (colmap/sparse_map.h) as a COLMAP workspace. docs/colmap-export.md
// describes the layout and every convention; in short:
//
//   <out>/sparse/0/        the model: binary (cameras, images, points3D, rigs,
//                          frames .bin), or text when only text is asked for
//   <out>/sparse_txt/0/    the same model as text, when both are asked for
//   <out>/images/<name>    the keyframe images (symlinks, copies, or remapped
//                          to the undistorted pinhole camera)
//
// Conventions. COLMAP ids start at 1: camera_id = rig camera index + 1;
// image ids count the (keyframe, camera) images in keyframe then camera
// order; point3D_id = landmark id + 1; frame_id = keyframe index + 1; one rig,
// rig_id 1. Poses are COLMAP's cam_from_world (images) and rig_from_world
// (frames). Pixels are COLMAP's: the centre of the top-left pixel is
// (0.5, 0.5), so 0.5 is added to principal points and to observations.
//
//   ColmapExportOptions options;  options.image_mode = ColmapImageMode::kLink;
//   const ColmapExportReport report = WriteColmapModel(rig, map, dataset_root, options, "out/colmap");
//   const ColmapModel model = ReadColmapModel("out/colmap/sparse/0");
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/map/sparse_map.h"
#include "mcvo/util/enum_names.h"

namespace mcvo {

// ---------------------------------------------------------------------------
// The model in memory.

// COLMAP camera models, with COLMAP's numeric ids (cameras.bin) and names
// (cameras.txt). The exporter writes PINHOLE, OPENCV, FULL_OPENCV and
// OPENCV_FISHEYE; the readers accept all of these.
enum class ColmapCameraModel : int {
  kSimplePinhole = 0,        // f cx cy
  kPinhole = 1,              // fx fy cx cy
  kSimpleRadial = 2,         // f cx cy k
  kRadial = 3,               // f cx cy k1 k2
  kOpenCv = 4,               // fx fy cx cy k1 k2 p1 p2
  kOpenCvFisheye = 5,        // fx fy cx cy k1 k2 k3 k4 (equidistant, theta = atan(r))
  kFullOpenCv = 6,           // fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6
  kFov = 7,                  // fx fy cx cy omega
  kSimpleRadialFisheye = 8,  // f cx cy k
  kRadialFisheye = 9,        // f cx cy k1 k2
  kThinPrismFisheye = 10,    // fx fy cx cy k1 k2 p1 p2 k3 k4 sx1 sy1
};

// "PINHOLE", "OPENCV_FISHEYE", ...
std::string_view ColmapCameraModelName(ColmapCameraModel model);
std::optional<ColmapCameraModel> ColmapCameraModelFromName(std::string_view name);
std::optional<ColmapCameraModel> ColmapCameraModelFromId(int id);
int ColmapCameraModelNumParams(ColmapCameraModel model);

// point3D id of a 2-D point without a 3-D point (-1 in images.txt).
inline constexpr uint64_t kColmapNoPoint3D = std::numeric_limits<uint64_t>::max();

struct ColmapCamera {
  uint32_t id = 0;
  ColmapCameraModel model = ColmapCameraModel::kPinhole;
  uint64_t width = 0;
  uint64_t height = 0;
  std::vector<double> params;  // COLMAP's order; principal point in COLMAP's pixel convention
};

struct ColmapImage {
  uint32_t id = 0;
  // Stored as written/read (the quaternion is not renormalised, so a model
  // reads back bit for bit).
  Rigid3d cam_from_world;
  uint32_t camera_id = 0;
  std::string name;  // path below the image folder, '/' separated
  std::vector<Eigen::Vector2d> points2d;
  std::vector<uint64_t> point3d_ids;  // same size as points2d; kColmapNoPoint3D: none
};

struct ColmapTrackElement {
  uint32_t image_id = 0;
  uint32_t point2d_idx = 0;
};

struct ColmapPoint3D {
  uint64_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::array<uint8_t, 3> rgb = {0, 0, 0};
  double error = 0.0;  // mean reprojection error of the track, pixels
  std::vector<ColmapTrackElement> track;
};

// COLMAP 3.12 rigs: the reference sensor defines the rig frame (its
// sensor_from_rig is the identity); every other sensor may have a pose.
// Only camera sensors are represented.
struct ColmapRigSensor {
  uint32_t camera_id = 0;
  std::optional<Rigid3d> sensor_from_rig;
};

struct ColmapRig {
  uint32_t id = 0;
  uint32_t ref_camera_id = 0;
  std::vector<ColmapRigSensor> sensors;  // the non-reference sensors, ascending camera id
};

struct ColmapFrameData {
  uint32_t camera_id = 0;
  uint64_t image_id = 0;
};

struct ColmapFrame {
  uint32_t id = 0;
  uint32_t rig_id = 0;
  Rigid3d rig_from_world;
  std::vector<ColmapFrameData> data;  // ascending camera id
};

// Every list ascending by id (the readers sort; the writers require it).
struct ColmapModel {
  std::vector<ColmapCamera> cameras;
  std::vector<ColmapImage> images;
  std::vector<ColmapPoint3D> points3d;
  std::vector<ColmapRig> rigs;      // empty: no rigs/frames files (COLMAP 3.8 layout)
  std::vector<ColmapFrame> frames;  // empty when rigs is

  const ColmapCamera* FindCamera(uint32_t id) const;
  const ColmapImage* FindImage(uint32_t id) const;
  const ColmapPoint3D* FindPoint3D(uint64_t id) const;
  int64_t NumObservations() const;  // 2-D points with a 3-D point, over all images
};

// Empty when the models are equal: same ids, names, models, sizes, tracks and
// 2-D point ids, and every real number within `tolerance` (absolute; 0:
// bit-equal up to the sign of zero). Else a one-line description of the first
// difference, for test messages.
std::string DiffColmapModels(const ColmapModel& a, const ColmapModel& b, double tolerance = 0.0);

// ---------------------------------------------------------------------------
// Files. Text numbers are written with the shortest decimal form that reads
// back to the same double, locale independent; binary files are little
// endian, byte for byte COLMAP's layout. Every file is written atomically
// (util/file.h). rigs and frames files are written when model.rigs is not
// empty. Readers throw InputError naming the file (and line) on bad input.

void WriteColmapModelText(const ColmapModel& model, const std::filesystem::path& dir);
void WriteColmapModelBinary(const ColmapModel& model, const std::filesystem::path& dir);
// Reads rigs and frames too when their files are present.
ColmapModel ReadColmapModelText(const std::filesystem::path& dir);
ColmapModel ReadColmapModelBinary(const std::filesystem::path& dir);
// As COLMAP: the binary files when cameras.bin, images.bin and points3D.bin
// are all there, else the text files.
ColmapModel ReadColmapModel(const std::filesystem::path& dir);

// The pixel (COLMAP convention) of a point in the camera frame, computed as
// COLMAP does (colmap/sensor/models.h): nullopt when the point is not in
// front of the camera (z < DBL_EPSILON, COLMAP's test) or the model is
// FOV, the fisheye models other than OPENCV_FISHEYE, or THIN_PRISM_FISHEYE
// (not implemented here).
std::optional<Eigen::Vector2d> ColmapProject(const ColmapCamera& camera, const Eigen::Vector3d& point_in_cam);

// ---------------------------------------------------------------------------
// Export of a run.

enum class ColmapImageMode {
  kNone,  // no images/ folder; image names still refer to the dataset's files
  kLink,  // images/<name> are symbolic links to the dataset's files (absolute targets)
  kCopy,  // images/<name> are copies
};
enum class ColmapModelFormat { kBinary, kText, kBoth };
// MEI and double-sphere cameras have no COLMAP model.
enum class ColmapFisheyePolicy {
  // OPENCV_FISHEYE fitted by least squares to the camera over the valid
  // image area up to fisheye_max_angle_deg; observations beyond it are
  // dropped; the report gives the fit's RMS and maximum pixel error.
  kFit,
  // A virtual PINHOLE camera (same pose) of at most undistort_fov_deg inside
  // the valid area; images are remapped to it (image_mode link or copy
  // required), observations reprojected and dropped outside its image.
  kUndistort,
};

inline constexpr EnumName<ColmapImageMode> kColmapImageModeNames[] = {
    {ColmapImageMode::kNone, "none"}, {ColmapImageMode::kLink, "link"}, {ColmapImageMode::kCopy, "copy"}};
inline constexpr EnumName<ColmapModelFormat> kColmapModelFormatNames[] = {
    {ColmapModelFormat::kBinary, "binary"},
    {ColmapModelFormat::kText, "text"},
    {ColmapModelFormat::kBoth, "both"}};
inline constexpr EnumName<ColmapFisheyePolicy> kColmapFisheyePolicyNames[] = {
    {ColmapFisheyePolicy::kFit, "fit"}, {ColmapFisheyePolicy::kUndistort, "undistort"}};

struct ColmapExportOptions {
  ColmapImageMode image_mode = ColmapImageMode::kLink;
  ColmapModelFormat format = ColmapModelFormat::kBoth;
  // rigs and frames files (COLMAP 3.12+; COLMAP 3.8 ignores them).
  bool write_rig_files = true;
  ColmapFisheyePolicy fisheye_policy = ColmapFisheyePolicy::kFit;
  // kFit: largest angle from the optical axis of the fit's samples and of the
  // kept observations. Below 90: COLMAP's OPENCV_FISHEYE divides by z.
  double fisheye_max_angle_deg = 85.0;
  // kFit: sample grid over the image, per axis (at most this squared samples).
  int fit_grid = 64;
  // kUndistort: field of view of the pinhole, per axis, reduced until the
  // pinhole image lies inside the fisheye's valid area.
  double undistort_fov_deg = 100.0;
  // Points with fewer observations (after the drops above) are not written.
  int min_track_length = 2;
  // Point colours: the mean of bilinear samples of the images at the
  // observations; 128 grey without images.
  bool sample_colors = true;
  // Replace a non-empty out_dir (else it is an error).
  bool overwrite = false;
  // Threads reading, sampling and writing images; the output is the same
  // for any number. 0: hardware concurrency.
  int threads = 1;

  // Throws InputError "/colmap/<field>: ..." naming the bad field.
  void Check() const;
};

// How one rig camera was written.
struct ColmapCameraExport {
  std::string name;  // rig camera name
  CameraModelId source_model = CameraModelId::kPinhole;
  ColmapCamera camera;       // as written
  bool fitted = false;       // kFit applied (MEI, double sphere)
  bool undistorted = false;  // kUndistort applied
  // Observations are kept up to this angle from the optical axis (bearing of
  // the observed pixel; 90: everything in front of the camera).
  double max_angle_deg = 90.0;
  // Fit: samples used, RMS and maximum pixel error of the fitted model
  // against the camera over the samples.
  int fit_samples = 0;
  double fit_rms_px = 0.0;
  double fit_max_px = 0.0;
  // Undistortion: the pinhole's full field of view per axis.
  double fov_x_deg = 0.0;
  double fov_y_deg = 0.0;
  int64_t observations_written = 0;
  int64_t observations_dropped = 0;  // outside max_angle / the pinhole image / behind the camera
};

// The COLMAP camera for a rig camera (camera_id = its 1-based id): exact for
// pinhole (PINHOLE), radtan (OPENCV, FULL_OPENCV when k3 != 0) and
// kannala_brandt (OPENCV_FISHEYE); MEI and double sphere by the policy.
// Reads the camera's mask (mask_path) when set, to restrict the fit samples
// and the pinhole view to valid pixels. Throws InputError when the camera's
// parameters are invalid, its mask cannot be read, or no fit / pinhole view
// inside the valid area exists.
ColmapCameraExport ConvertCameraToColmap(const Camera& camera, uint32_t camera_id,
                                         const ColmapExportOptions& options);

struct ColmapExportReport {
  std::filesystem::path model_dir;  // <out>/sparse/0
  std::filesystem::path text_dir;   // where the text files are (model_dir or <out>/sparse_txt/0), empty: none
  std::filesystem::path image_dir;  // <out>/images, empty when image_mode is none
  int cameras = 0;
  int images = 0;
  int points = 0;
  int64_t observations = 0;
  // model_analyzer's "Mean reprojection error": the mean over points of each
  // point's mean reprojection error (pixels, through the written cameras).
  double mean_reprojection_error_px = 0.0;
  double mean_track_length = 0.0;
  int64_t observations_dropped = 0;  // sum over cameras (see ColmapCameraExport)
  int64_t landmarks_dropped = 0;     // landmarks with fewer than min_track_length observations left
  int images_written = 0;            // files in images/ (links, copies or remapped)
  int images_without_source = 0;     // (keyframe, camera) images without a dataset image
  int images_without_color = 0;      // images that could not be read for colours
  std::vector<ColmapCameraExport> camera_exports;  // rig camera order
  std::vector<std::string> notes;                  // what a user should know, one line each
};

// Point colours sampled ahead of the export from images decoded for another
// reason (a run's loop stage reads every keyframe's images): one image's
// pixels (source image, OpenCV convention) and their colours, as
// SampleColmapColors gives them.
struct ColmapColorSamples {
  std::vector<Eigen::Vector2d> pixels;  // ascending (x, then y), unique
  std::vector<Eigen::Vector3d> colors;  // RGB in [0, 255]
  std::vector<bool> has_color;          // false: a bilinear neighbour is outside the image
  // The index of exactly this pixel in `pixels`, -1 when it was not sampled.
  int Find(const Eigen::Vector2d& pixel) const;
};
// Per (frame index of the map keyframe, rig camera index).
using ColmapColorTable = std::map<std::pair<int, int>, ColmapColorSamples>;

// A dataset image decoded as the export samples its colours: cv::imread with
// IMREAD_ANYDEPTH | IMREAD_ANYCOLOR (depth and colour kept, alpha dropped, the EXIF
// orientation applied as in the frontend's IMREAD_GRAYSCALE reads, so the
// observations' pixels fall on the same image); an empty Mat when the file
// is missing or cannot be decoded.
cv::Mat DecodeColmapColorImage(const std::filesystem::path& path);

// Samples `pixels` of a decoded image (DecodeColmapColorImage; any depth and
// channel count) exactly as the export does:
// the image as 8-bit BGR, each pixel's colour bilinear, none where a
// neighbour is outside the image (COLMAP's color_extractor). Duplicate
// pixels are sampled once.
ColmapColorSamples SampleColmapColors(const cv::Mat& decoded, std::vector<Eigen::Vector2d> pixels);

// Writes the COLMAP workspace of `map` into out_dir (layout above), staged
// in "<out_dir>.tmp-<pid>" and renamed when complete: out_dir is complete or
// absent. Image paths of the keyframes are resolved against dataset_root
// when relative. An image is written for every (keyframe, camera) with a
// dataset image or an observation. Throws InputError on bad input (a map that
// does not fit the rig, a missing image in link/copy mode, an existing
// non-empty out_dir without overwrite) and UsageError when kUndistort
// applies to a camera and image_mode is none.
// colors (optional): an image whose observation pixels are all in the table
// (with sample_colors on and no undistortion to write) takes its colours from
// there and is not decoded; the model is the same as without the table when
// the table was sampled from the same files.
ColmapExportReport WriteColmapModel(const Rig& rig, const SparseMap& map,
                                    const std::filesystem::path& dataset_root,
                                    const ColmapExportOptions& options, const std::filesystem::path& out_dir,
                                    const ColmapColorTable* colors = nullptr);

// The report as a few human-readable lines (counts, mean error, each camera's
// mapping and fit, notes).
std::string DescribeColmapExport(const ColmapExportReport& report);

}  // namespace mcvo
