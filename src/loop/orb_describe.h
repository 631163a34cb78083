// ORB descriptors at given pixels (private to loop/): the loop closer's
// landmark pixels and the cross-camera links' (loop/cross_camera_links.h).
#pragma once

#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

namespace mcvo::loop_internal {

// ORB's orientation of a keypoint (Rublee et al.: the direction from the
// centre to the intensity centroid of the disc of `radius` around it), in
// degrees [0, 360), on the level-0 image; 0 where the disc leaves the image.
// cv::ORB::compute keeps a given keypoint's angle (-1 when unset: an
// upright descriptor), which does not match the oriented descriptors of its
// own detections.
float IntensityCentroidAngle(const cv::Mat& image, float x, float y, int radius);

// Oriented ORB descriptors on level 0 (size 31) at `pixels` of `image`;
// `kept` gets the indices of the pixels ORB kept (not at the border), in
// the order of the descriptors' rows.
void DescribeOriented(const cv::Ptr<cv::ORB>& orb, const cv::Mat& image,
                      const std::vector<cv::Point2f>& pixels, std::vector<int>* kept, cv::Mat* descriptors);

}  // namespace mcvo::loop_internal
