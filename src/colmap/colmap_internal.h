// Internals of the colmap module shared by its sources (not installed API).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/colmap/colmap_model.h"

namespace mcvo::colmap_internal {

// COLMAP's SensorType CAMERA: 0 in binary files, "CAMERA" in text files.
inline constexpr int kSensorCamera = 0;
inline constexpr std::string_view kSensorCameraName = "CAMERA";

// After reading the files of `dir` (extension ".txt" or ".bin"): sorts every
// list by id, rejects duplicate ids and rigs without frames (or the reverse)
// with InputError naming the file.
void FinishReadModel(const std::filesystem::path& dir, const std::string& extension, ColmapModel* model);

// MCVO_CHECKs what the writers need: ascending ids, parameter counts, one
// point3D id per 2-D point, names without blanks.
void CheckWritableModel(const ColmapModel& model);

// Angle of a bearing from the optical axis, degrees.
double AngleFromAxisDeg(const Eigen::Vector3d& bearing);

// The valid-pixel mask of a camera (CV_8UC1, 255 valid) read from
// camera.mask_path; an empty Mat when the camera has none. Throws InputError
// when the file cannot be read or its size is not the camera's.
cv::Mat ReadCameraMask(const Camera& camera);

// The undistorted pinhole camera's pixel (COLMAP convention) seeing the same
// bearing as `pixel` (OpenCV convention) of `camera`; nullopt when the pixel
// does not unproject, looks backwards, or lands outside the pinhole image.
std::optional<Eigen::Vector2d> UndistortPixel(const Camera& camera, const ColmapCamera& pinhole,
                                              const Eigen::Vector2d& pixel);

// cv::remap maps (CV_32FC1 each, the pinhole's size) from the PINHOLE camera
// `pinhole` to `camera`'s image, in OpenCV's pixel convention; -1 where the
// camera cannot see the pinhole pixel's bearing.
void MakeUndistortMaps(const Camera& camera, const ColmapCamera& pinhole, cv::Mat* map_x, cv::Mat* map_y);

// Colours (colmap_colors.cc; decoding: DecodeColmapColorImage). Any decoded
// image as 8-bit BGR.
cv::Mat ToBgr8(const cv::Mat& image);
// Bilinear sample (OpenCV pixel convention) of an 8-bit BGR image as RGB;
// false when a neighbour is outside the image (as COLMAP's color_extractor).
bool SampleBilinear(const cv::Mat& bgr, const Eigen::Vector2d& pixel, Eigen::Vector3d* rgb);

}  // namespace mcvo::colmap_internal
