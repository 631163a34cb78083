// The loop closer's keyframe input (relocalise_segments.h ToLoopKeyframe):
// one decode per image gives both the grey image (the frontend's) and the
// COLMAP colours, for grey, colour, colour-with-alpha and 16-bit files.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "../../src/pipeline/relocalise_segments.h"
#include "mcvo/util/error.h"

namespace mcvo::pipeline_internal {
namespace {

namespace fs = std::filesystem;

// A textured 8-bit image whose value at (x, y) depends on both and on `salt`.
cv::Mat Pattern(int width, int height, int salt) {
  cv::Mat image(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x)
      image.at<uint8_t>(y, x) = static_cast<uint8_t>((x * 7 + y * 13 + salt * 31) % 251);
  }
  return image;
}

int MaxAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  double max = 0.0;
  cv::minMaxLoc(cv::abs(a - b), nullptr, &max);
  return static_cast<int>(max);
}

class LoopKeyframeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mcvo_loop_keyframe_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const int w = 64, h = 48;
    // Camera 0: colour, its three channels different.
    bgr_ = cv::Mat();
    cv::merge(std::vector<cv::Mat>{Pattern(w, h, 1), Pattern(w, h, 2), Pattern(w, h, 3)}, bgr_);
    Write("colour.png", bgr_);
    // Camera 1: 8-bit grey.
    grey_ = Pattern(w, h, 4);
    Write("grey.png", grey_);
    // Camera 2: 16-bit grey.
    cv::Mat wide;
    Pattern(w, h, 5).convertTo(wide, CV_16U, 257.0);
    wide += cv::Scalar(100);  // low bytes that an 8-bit grey decode must drop
    Write("wide.png", wide);
    // Camera 3: colour with alpha.
    cv::Mat bgra;
    cv::merge(std::vector<cv::Mat>{Pattern(w, h, 6), Pattern(w, h, 7), Pattern(w, h, 8),
                                   cv::Mat(h, w, CV_8UC1, cv::Scalar(255))},
              bgra);
    Write("alpha.png", bgra);

    for (int c = 0; c < 4; ++c) {
      Camera camera;
      camera.name = "cam" + std::to_string(c);
      camera.width = w;
      camera.height = h;
      index_.rig.cameras.push_back(camera);
    }
    DatasetFrame frame;
    for (const char* name : {"colour.png", "grey.png", "wide.png", "alpha.png"})
      frame.images.push_back(dir_ / name);
    index_.frames.push_back(frame);
    keyframe_.frame_index = 0;
    for (int c = 0; c < 4; ++c) {
      keyframe_.observations.push_back({c, 10 + c, Eigen::Vector2d(20.0, 30.0)});
      keyframe_.observation_points.push_back(Eigen::Vector3d(1.0, 2.0, 3.0 + c));
    }
  }
  void TearDown() override { fs::remove_all(dir_); }

  void Write(const std::string& name, const cv::Mat& image) const {
    ASSERT_TRUE(cv::imwrite((dir_ / name).string(), image)) << name;
  }
  cv::Mat ReadGrey(const std::string& name) const {
    return cv::imread((dir_ / name).string(), cv::IMREAD_GRAYSCALE);
  }

  fs::path dir_;
  cv::Mat bgr_, grey_;
  DatasetIndex index_;
  KeyframeEstimate keyframe_;
};

TEST_F(LoopKeyframeTest, OneDecodeGivesTheGreyImageAndTheColours) {
  for (int threads : {1, 2}) {
    std::vector<ColmapColorSamples> colors;
    const LoopKeyframe lk = ToLoopKeyframe(index_, keyframe_, threads, &colors);
    ASSERT_EQ(lk.images.size(), 4u);
    for (const cv::Mat& image : lk.images) {
      ASSERT_EQ(image.type(), CV_8UC1);
      ASSERT_EQ(image.size(), cv::Size(64, 48));
    }
    // Colour: OpenCV's BT.601 grey of the colour decode (dataset.h
    // GreyOfDecodedImage, as the frontend's), within a grey level of the
    // decoder's own grey (libpng's conversion truncates).
    cv::Mat expected;
    cv::cvtColor(bgr_, expected, cv::COLOR_BGR2GRAY);
    EXPECT_EQ(MaxAbsDiff(lk.images[0], expected), 0);
    EXPECT_LE(MaxAbsDiff(lk.images[0], ReadGrey("colour.png")), 1);
    // Grey: the file's pixels.
    EXPECT_EQ(MaxAbsDiff(lk.images[1], grey_), 0);
    // 16-bit: the high byte, as IMREAD_GRAYSCALE gives it.
    EXPECT_EQ(MaxAbsDiff(lk.images[2], ReadGrey("wide.png")), 0);
    // Colour with alpha: the grey of its colour channels.
    cv::Mat bgr3 = cv::imread((dir_ / "alpha.png").string(), cv::IMREAD_COLOR);
    cv::cvtColor(bgr3, expected, cv::COLOR_BGR2GRAY);
    EXPECT_EQ(MaxAbsDiff(lk.images[3], expected), 0);

    // Every grey image is the frontend's (FrameStream's) of the same file.
    const char* names[] = {"colour.png", "grey.png", "wide.png", "alpha.png"};
    for (size_t c = 0; c < 4; ++c) {
      const cv::Mat decoded =
          cv::imread((dir_ / names[c]).string(), cv::IMREAD_ANYCOLOR | cv::IMREAD_ANYDEPTH);
      EXPECT_EQ(MaxAbsDiff(lk.images[c], GreyOfDecodedImage(decoded)), 0) << names[c];
    }

    // The colours at the observation pixel (an integer pixel: no blending),
    // RGB from the same decode.
    ASSERT_EQ(colors.size(), 4u);
    const Eigen::Vector2d pixel(20.0, 30.0);
    const int i = colors[0].Find(pixel);
    ASSERT_GE(i, 0);
    ASSERT_TRUE(colors[0].has_color[static_cast<size_t>(i)]);
    const cv::Vec3b bgr = bgr_.at<cv::Vec3b>(30, 20);
    EXPECT_DOUBLE_EQ(colors[0].colors[static_cast<size_t>(i)].x(), bgr[2]);
    EXPECT_DOUBLE_EQ(colors[0].colors[static_cast<size_t>(i)].y(), bgr[1]);
    EXPECT_DOUBLE_EQ(colors[0].colors[static_cast<size_t>(i)].z(), bgr[0]);
    const int g = colors[1].Find(pixel);
    ASSERT_GE(g, 0);
    EXPECT_DOUBLE_EQ(colors[1].colors[static_cast<size_t>(g)].x(), grey_.at<uint8_t>(30, 20));

    // The landmarks, with their points, in observation order.
    ASSERT_EQ(lk.points.size(), 4u);
    EXPECT_EQ(lk.points[3].camera, 3);
    EXPECT_EQ(lk.points[3].landmark_id, 13);
  }
}

TEST_F(LoopKeyframeTest, WithoutColoursTheGreyImagesAreTheSame) {
  std::vector<ColmapColorSamples> colors;
  const LoopKeyframe with = ToLoopKeyframe(index_, keyframe_, 2, &colors);
  const LoopKeyframe without = ToLoopKeyframe(index_, keyframe_, 2);
  ASSERT_EQ(without.images.size(), 4u);
  for (size_t c = 0; c < 4; ++c) EXPECT_EQ(MaxAbsDiff(with.images[c], without.images[c]), 0) << c;
}

TEST_F(LoopKeyframeTest, WithoutImagesEverythingButTheImages) {
  const LoopKeyframe lk = LoopKeyframeWithoutImages(keyframe_, 4);
  ASSERT_EQ(lk.images.size(), 4u);
  for (const cv::Mat& image : lk.images) EXPECT_TRUE(image.empty());
  const LoopKeyframe full = ToLoopKeyframe(index_, keyframe_, 1);
  ASSERT_EQ(lk.points.size(), full.points.size());
  for (size_t k = 0; k < lk.points.size(); ++k) {
    EXPECT_EQ(lk.points[k].camera, full.points[k].camera);
    EXPECT_EQ(lk.points[k].landmark_id, full.points[k].landmark_id);
    EXPECT_EQ(lk.points[k].pixel, full.points[k].pixel);
    EXPECT_EQ(lk.points[k].point_in_world, full.points[k].point_in_world);
  }
}

TEST_F(LoopKeyframeTest, AnUnreadableImageIsAnErrorNamingIt) {
  std::ofstream(dir_ / "grey.png", std::ios::trunc) << "not a png";
  std::vector<ColmapColorSamples> colors;
  try {
    ToLoopKeyframe(index_, keyframe_, 2, &colors);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("grey.png"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mcvo::pipeline_internal
