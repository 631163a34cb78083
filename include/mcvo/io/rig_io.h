// rig.json: cameras, intrinsics, extrinsics and masks of a rig. The schema is
// documented in docs/rig-json.md.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "mcvo/camera/camera.h"

namespace mcvo {

// Tolerances of the rig.json checks. Calibration files commonly print
// rotations with 6 decimals (KITTI-360 R_rect: |R^T R - I| ~ 1e-6), hence 1e-5.
inline constexpr double kRigRotationTolerance = 1e-5;    // max |R^T R - I|
inline constexpr double kRigQuaternionTolerance = 1e-5;  // max |1 - |q||

// Reads and validates a rig.json. Every problem throws InputError with one
// line "<path>: <JSON path>: <what is wrong>". Accepted rotations are
// projected onto SO(3); mask paths are resolved against the folder of `path`
// and stored absolute and normalised.
Rig ReadRig(const std::filesystem::path& path);
// As ReadRig, from JSON text; `source` names it in errors and relative mask
// paths are resolved against `base_dir`.
Rig ParseRigJson(const std::string& text, const std::string& source, const std::filesystem::path& base_dir);

// Writes the rig atomically (cam_from_rig as quaternion_wxyz + translation,
// mask paths relative to the folder of `path`). ReadRig(WriteRig(rig)) gives
// back the same numbers bit for bit.
void WriteRig(const std::filesystem::path& path, const Rig& rig);
std::string RigToJson(const Rig& rig, const std::filesystem::path& base_dir);

// Names of the parameters of a model in rig.json order ("fx", "fy", ...).
std::vector<std::string> CameraModelParamNames(CameraModelId model);

}  // namespace mcvo
