// Point colours sampled ahead of the export (ColmapColorTable: what a run's
// loop stage samples while it reads the keyframe images): the export takes
// an image's colours from the table when it has every observation pixel,
// without decoding the image, and the model is the one it writes alone.
#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "colmap/colmap_fixture.h"
#include "mcvo/colmap/colmap_model.h"

namespace mcvo {
namespace {

using test::ScratchDir;
namespace fs = std::filesystem;

// Colours that change across the image (bilinear samples differ by pixel).
cv::Mat Gradient(const Camera& camera) {
  cv::Mat image(camera.height, camera.width, CV_8UC3);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      image.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uint8_t>(x % 251), static_cast<uint8_t>(y % 241),
                                            static_cast<uint8_t>((3 * x + 5 * y) % 256));
    }
  }
  return image;
}

// Every (keyframe, camera) image's observation pixels, sampled from its file.
ColmapColorTable SampleTable(const Rig& rig, const SparseMap& map, const fs::path& root) {
  ColmapColorTable table;
  for (const MapKeyframe& keyframe : map.keyframes) {
    for (int c = 0; c < rig.NumCameras(); ++c) {
      std::vector<Eigen::Vector2d> pixels;
      for (const MapObservation& ob : keyframe.observations) {
        if (ob.camera == c) pixels.push_back(ob.pixel);
      }
      table[{keyframe.frame_index, c}] =
          SampleColmapColors(DecodeColmapColorImage(root / keyframe.images[c]), std::move(pixels));
    }
  }
  return table;
}

TEST(ColmapColors, SamplesAreSortedUniqueAndFoundExactly) {
  const cv::Mat image(4, 5, CV_8UC1, cv::Scalar(90));
  const ColmapColorSamples samples =
      SampleColmapColors(image, {{3.0, 1.0}, {1.5, 2.25}, {3.0, 1.0}, {1.5, 0.5}, {4.2, 1.0}});
  ASSERT_EQ(samples.pixels.size(), 4u);
  EXPECT_EQ(samples.pixels[0], Eigen::Vector2d(1.5, 0.5));
  EXPECT_EQ(samples.pixels[1], Eigen::Vector2d(1.5, 2.25));
  EXPECT_EQ(samples.pixels[2], Eigen::Vector2d(3.0, 1.0));
  EXPECT_EQ(samples.Find({3.0, 1.0}), 2);
  EXPECT_EQ(samples.Find({3.0, 1.0000001}), -1);
  EXPECT_EQ(samples.Find({0.0, 0.0}), -1);
  EXPECT_TRUE(samples.has_color[2]);
  EXPECT_EQ(samples.colors[2], Eigen::Vector3d(90, 90, 90));
  // x 4.2: its right neighbour is outside the 5-pixel-wide image.
  EXPECT_FALSE(samples.has_color[samples.Find({4.2, 1.0})]);
  // Nothing decoded: no colours.
  const ColmapColorSamples none = SampleColmapColors(cv::Mat(), {{1.0, 1.0}});
  ASSERT_EQ(none.has_color.size(), 1u);
  EXPECT_FALSE(none.has_color[0]);
}

TEST(ColmapColors, TheTableGivesTheExportsOwnColoursWithoutDecoding) {
  ScratchDir dir("export_color_table");
  const Rig rig = test::ThreeCameraRig(0.5, 0.25);
  const SparseMap map = test::ProjectedMap(rig, test::KeyframePoses(3), test::RandomPoints(120, 4));
  const fs::path root = dir.path() / "dataset";
  test::WriteImages(rig, map, root, Gradient);
  ColmapExportOptions options;
  options.image_mode = ColmapImageMode::kNone;
  const ColmapExportReport alone = WriteColmapModel(rig, map, root, options, dir.path() / "alone");
  ColmapColorTable table = SampleTable(rig, map, root);
  const ColmapExportReport with_table =
      WriteColmapModel(rig, map, root, options, dir.path() / "table", &table);
  EXPECT_EQ(with_table.images_without_color, 0);
  EXPECT_TRUE(test::TreeContents(dir.path() / "alone") == test::TreeContents(dir.path() / "table"));
  // The colours vary: the comparison above is not between constant images.
  std::vector<std::array<uint8_t, 3>> colours;
  for (const ColmapPoint3D& point : ReadColmapModel(alone.model_dir).points3d) colours.push_back(point.rgb);
  ASSERT_GT(colours.size(), 20u);
  EXPECT_NE(colours.front(), colours.back());

  // No image files at all: the table's colours are used (nothing decoded).
  for (auto& [key, samples] : table) {
    for (Eigen::Vector3d& colour : samples.colors) colour = Eigen::Vector3d(1, 2, 3);
  }
  fs::remove_all(root);
  const ColmapExportReport from_table =
      WriteColmapModel(rig, map, root, options, dir.path() / "fixed", &table);
  EXPECT_EQ(from_table.images_without_color, 0);
  for (const ColmapPoint3D& point : ReadColmapModel(from_table.model_dir).points3d) {
    EXPECT_EQ(point.rgb, (std::array<uint8_t, 3>{1, 2, 3}));
  }

  // An image whose pixels the table lacks one of is decoded (here: missing).
  ColmapColorSamples& first = table.at({map.keyframes[0].frame_index, 0});
  ASSERT_FALSE(first.pixels.empty());
  first.pixels.erase(first.pixels.begin());
  first.colors.erase(first.colors.begin());
  first.has_color.erase(first.has_color.begin());
  const ColmapExportReport partial =
      WriteColmapModel(rig, map, root, options, dir.path() / "partial", &table);
  EXPECT_EQ(partial.images_without_color, 1);
}

}  // namespace
}  // namespace mcvo
