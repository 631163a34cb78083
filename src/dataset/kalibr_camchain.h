// Private: the Kalibr camchain.yaml reader, shared by the Kalibr layout
// (kalibr_reader.cc) and ROS bags calibrated by a camchain (rosbag_reader.cc).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "mcvo/camera/camera.h"

namespace mcvo::dataset_internal {

// All cameras cam0, cam1, ... of the camchain, named camN, with cam_from_rig
// set (rig frame: cam0, or the IMU when cam0 has T_cam_imu; kalibr_reader.cc).
// Appends what it did to *log. With rostopics, appends each camera's
// `rostopic` (empty when the entry has none). Throws InputError naming the
// file, line and key.
std::vector<Camera> ReadCamchain(const std::filesystem::path& path, std::vector<std::string>* log,
                                 std::vector<std::string>* rostopics = nullptr);

}  // namespace mcvo::dataset_internal
