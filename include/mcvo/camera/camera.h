// Run-time camera description and dispatch over the templated models in
// camera/models.h. This is the edge where a model is chosen at run time; the
// inner loops (Ceres functors, projection of many points) use the templated
// model types directly.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

// Camera models. The parameter order of each is documented in
// camera/models.h and docs/rig-json.md.
enum class CameraModelId {
  kPinhole,        // fx fy cx cy
  kRadTan,         // fx fy cx cy k1 k2 p1 p2 k3       (OpenCV; JSON may omit k3)
  kKannalaBrandt,  // fx fy cx cy k1 k2 k3 k4          (equidistant fisheye, cv::fisheye)
  kMei,            // xi k1 k2 p1 p2 gamma1 gamma2 u0 v0 (unified omnidirectional, cv::omnidir, KITTI-360)
  kDoubleSphere,   // fx fy cx cy xi alpha             (Usenko et al. 2018)
};

// Names as used in rig.json: "pinhole", "radtan", "kannala_brandt", "mei",
// "double_sphere".
std::string_view CameraModelName(CameraModelId id);
// Inverse of CameraModelName; also accepts the aliases "opencv" (radtan),
// "equidistant" and "fisheye" (kannala_brandt), "omni" and "unified" (mei).
std::optional<CameraModelId> CameraModelFromName(std::string_view name);
// The fisheye models (kannala_brandt, mei, double_sphere): the frontend's
// max_features_fisheye budget; the others take max_features_pinhole.
bool IsFisheyeModel(CameraModelId id);
// Number of parameters stored for the model (radtan: 9, k3 included).
int CameraModelNumParams(CameraModelId id);
// Empty when `params` are usable for the model, else a one-line reason
// ("expected 9 parameters, got 8", "fx and fy must be > 0", ...), for the
// readers that validate user input (they add the file and JSON path).
std::string CameraParamsError(CameraModelId id, const std::vector<double>& params);

// One camera of the rig. Pixel convention: OpenCV's, the centre of the
// top-left pixel is (0, 0).
struct Camera {
  std::string name;
  CameraModelId model = CameraModelId::kPinhole;
  std::vector<double> params;  // CameraModelNumParams(model) values
  int width = 0;
  int height = 0;
  Rigid3d cam_from_rig;
  std::string mask_path;  // empty: no mask (absolute path once loaded)

  // The methods below MCVO_CHECK that params.size() == CameraModelNumParams
  // (callers validate user input with CameraParamsError first).
  //
  // Projects a point in the camera frame to pixels. std::nullopt when the
  // point is outside the model's valid domain (behind a pinhole camera,
  // beyond a fisheye's maximum angle, ...). Does not test the image bounds.
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& point_in_cam) const;
  // As Project, also returning d(pixel)/d(point_in_cam).
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& point_in_cam,
                                         Eigen::Matrix<double, 2, 3>* jacobian) const;
  // Unit bearing vector of a pixel; std::nullopt outside the model's image of
  // its valid domain.
  std::optional<Eigen::Vector3d> Unproject(const Eigen::Vector2d& pixel) const;
  // True when the pixel is inside the image rectangle [0, w) x [0, h) in
  // OpenCV's pixel-centre convention (-0.5 .. w-0.5).
  bool IsInImage(const Eigen::Vector2d& pixel) const;
  // A representative focal length in pixels, for pixel thresholds: the
  // pixels per radian at the principal point, mean of u and v. Pinhole,
  // radtan, KB: (fx + fy) / 2; MEI: (gamma1 + gamma2) / 2 / (1 + xi);
  // double sphere: (fx + fy) / 2 / (1 + xi).
  double MeanFocalLength() const;
};

// The camera seeing the same scene in images resized by `scale` (0.5: half
// width and height): image size rounded to whole pixels, focal lengths and
// principal point scaled by the actual per-axis ratio, in OpenCV's
// pixel-centre convention (c' = r (c + 0.5) - 0.5). Distortion is unchanged
// (it acts on normalised coordinates). The mask path is kept (a mask must be
// resized by whoever reads it). Throws InputError when scale is not in
// (0, 4] or the image would be empty.
Camera ScaledCamera(const Camera& camera, double scale);

// A rigid rig of N >= 1 cameras with unique names. The rig frame is the body
// frame of the dataset (KITTI-360: the GPS/IMU pose frame).
struct Rig {
  std::vector<Camera> cameras;

  int NumCameras() const { return static_cast<int>(cameras.size()); }
  // Index of the camera with this name, or -1.
  int FindCamera(std::string_view name) const;
  // Every camera's cam_from_rig, in rig order.
  std::vector<Rigid3d> CamFromRig() const;
};

// Camera names become folder and file names of the outputs (images/<camera>/,
// masks/<camera>.png, colmap/images/<camera>/), so a name must be one safe,
// portable path component: not empty, at most kMaxCameraNameBytes bytes of
// valid UTF-8, not starting with '.' (so neither "." nor "..") or '-', and
// without '/', '\\' or control characters (C0, DEL, C1). Other Unicode
// letters are fine.
inline constexpr size_t kMaxCameraNameBytes = 100;

// Why `name` cannot name a camera, e.g. "\"../x\" is not a safe folder name:
// must not contain '/'" (the name escaped by EscapeForMessage so the message
// stays one line), or "" when it can.
std::string ValidateCameraName(std::string_view name);

// The check every rig goes through once, wherever it is read or built:
// each name passes ValidateCameraName and no two names are equal ignoring
// ASCII letter case (folders on case-insensitive file systems). Throws
// InputError "<source>: <where(i)>: <what>" for the first bad camera i;
// `where` gives the place of camera i's name in the source (a JSON pointer,
// a YAML key, ...).
void ValidateRigCameraNames(const Rig& rig, const std::string& source,
                            const std::function<std::string(size_t)>& where);

}  // namespace mcvo
