// Writes a dataset in the KITTI-360 layout (docs/datasets.md, "KITTI-360"):
// a converter from any DatasetIndex with a KITTI-360-shaped rig, and the
// fixture writer of the KITTI-360 reader's round-trip tests.
//
//   ROOT/calibration/calib_cam_to_pose.txt   pose_from_cam per camera
//   ROOT/calibration/perspective.txt         S_rect, P_rect, R_rect (image_00/01)
//   ROOT/calibration/image_02.yaml, image_03.yaml   MEI intrinsics
//   ROOT/calibration/mask_02.png, mask_03.png       fisheye masks (when the source has them)
//   ROOT/data_2d_raw/SEQ/image_0N/{data_rect,data_rgb}/%010d.png, timestamps.txt
//   ROOT/data_poses/SEQ/poses.txt            ground truth (frame index + 3x4 world_from_pose)
#pragma once

#include <filesystem>
#include <string>

#include "mcvo/dataset/dataset.h"

namespace mcvo {

// The rig must hold pinhole cameras named image_00 / image_01 (image_01 only
// with image_00) and/or MEI cameras named image_02 / image_03; otherwise
// InputError. Frame i of `source` becomes frame index i: every camera's
// timestamps.txt holds every frame's t_ns, and a missing image is a missing
// file. The rectified cameras are written with the published R_rect_00 /
// R_rect_01 and pose_from_cam composed so that ReadKitti360Dataset gives
// back source.rig (cam_from_rig to ~1e-15; numbers written in the shortest
// form that reads back exactly). PNG images are copied byte for byte (other
// formats are re-encoded as PNG). Ground-truth poses at a frame time go to
// poses.txt under that frame's index; poses at other times are dropped.
// Masks of pinhole cameras have no place in the layout and are dropped.
void WriteKitti360Layout(const DatasetIndex& source, const std::filesystem::path& root,
                         const std::string& sequence);

}  // namespace mcvo
