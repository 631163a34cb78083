// ONNX keypoint networks run with OpenCV DNN: XFeat (the default learned
// detector) and SuperPoint-layout networks (65-channel cell logits + a
// descriptor map). Any compatible model by path.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core/mat.hpp>

#include "mcvo/frontend/detector.h"

namespace mcvo {

struct CellLogitsDecodeOptions {
  float threshold = 0.015f;  // keypoint probability after the 65-way softmax
  int nms_radius_px = 2;     // at network resolution; 0: no suppression
  int border_px = 4;         // at network resolution
  int max_keypoints = 0;     // 0: no limit
};

// Decodes network outputs at network resolution (H = 8 Hc, W = 8 Wc):
//  - cell_logits: CV_32F, dims {65, Hc, Wc} (batch dropped); channel k < 64 is
//    pixel (k / 8, k % 8) of the 8x8 cell, channel 64 "no keypoint";
//  - descriptor_map: CV_32F {D, Hc, Wc} or empty;
//  - reliability: CV_32F {1, Hc, Wc} (XFeat heatmap, already a probability) or empty.
// Softmax over the 65 channels, drop channel 64, pixel shuffle to H x W,
// score = probability (x bilinear reliability when given), threshold, border,
// NMS (a point survives when it is the maximum within nms_radius_px,
// ties broken by position), then descriptors by bilinear sampling of the map
// at the keypoint (cell centres at 8 c + 3.5) and L2-normalised.
// Pixels are then scaled by (scale_x, scale_y) to the original image
// (x_image = (x_net + 0.5) * scale - 0.5).
Detections DecodeCellLogits(const cv::Mat& cell_logits, const cv::Mat& descriptor_map, const cv::Mat& reliability,
                            const CellLogitsDecodeOptions& options, double scale_x, double scale_y);

enum class KeypointNetLayout {
  kXFeat,       // outputs: 65-ch keypoint logits, 64-ch feats, 1-ch heatmap
  kSuperPoint,  // outputs: 65-ch cell logits, D-ch descriptor map
};

// Loads an ONNX model, identifies its layout from the output shapes (and
// names), checks the input is [1, 1, H, W] with H, W multiples of 8, and runs
// one forward pass on a blank image so that a broken model fails at start-up.
// Throws InputError "<model file>: <what is wrong>".
class KeypointNetDetector : public Detector {
 public:
  KeypointNetDetector(const std::filesystem::path& model_path, const FrontendOptions& options);
  ~KeypointNetDetector() override;
  std::string Name() const override;
  Detections Detect(const cv::Mat& image, const cv::Mat& mask, int max_candidates, int border_px) override;
  int DescriptorSize() const override;
  KeypointNetLayout layout() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
