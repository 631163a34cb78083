#include <gtest/gtest.h>

#include "camera/test_cameras.h"
#include "mcvo/camera/camera.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

// Resizing an image by r maps a pixel u (OpenCV centre convention) to
// r (u + 0.5) - 0.5. A scaled camera must project every point there.
TEST(ScaledCamera, ProjectionsFollowTheResizedImageForEveryModel) {
  for (const Camera& camera : test::AllTestCameras()) {
    for (double scale : {0.25, 0.5, 1.0, 1.5}) {
      const Camera scaled = ScaledCamera(camera, scale);
      const double rx = static_cast<double>(scaled.width) / camera.width;
      const double ry = static_cast<double>(scaled.height) / camera.height;
      EXPECT_NEAR(rx, scale, 0.5 / camera.width * 2) << camera.name;
      int checked = 0;
      for (int i = 0; i < 200; ++i) {
        const Eigen::Vector3d point(std::sin(0.37 * i) * 2.0, std::cos(0.23 * i) * 1.5,
                                    3.0 + std::sin(0.11 * i));
        const auto pixel = camera.Project(point);
        const auto scaled_pixel = scaled.Project(point);
        ASSERT_EQ(pixel.has_value(), scaled_pixel.has_value()) << camera.name;
        if (!pixel) continue;
        EXPECT_NEAR(scaled_pixel->x(), rx * (pixel->x() + 0.5) - 0.5, 1e-9) << camera.name;
        EXPECT_NEAR(scaled_pixel->y(), ry * (pixel->y() + 0.5) - 0.5, 1e-9) << camera.name;
        ++checked;
      }
      EXPECT_GT(checked, 50) << camera.name;
    }
  }
}

TEST(ScaledCamera, RejectsBadScales) {
  const Camera camera = test::Kitti360Image02();
  EXPECT_THROW(ScaledCamera(camera, 0.0), InputError);
  EXPECT_THROW(ScaledCamera(camera, -1.0), InputError);
  EXPECT_THROW(ScaledCamera(camera, 1e-5), InputError);  // no pixels left
}

}  // namespace
}  // namespace mcvo
