// Private: the mask file a rig.json names for a camera, shared by the
// generic layout and ROS bags calibrated by a rig.json.
#pragma once

#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"

namespace mcvo::dataset_internal {

// camera.mask_path read as CV_8UC1, 255 = valid (any non-zero value), of the
// camera's size. Throws InputError naming the file.
cv::Mat ReadRigMask(const Camera& camera);

}  // namespace mcvo::dataset_internal
