// ONNX keypoint networks run with OpenCV DNN: XFeat (the default learned
// detector) and SuperPoint-layout networks (65-channel cell logits + a
// descriptor map). Any compatible model by path.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "mcvo/frontend/detector.h"

namespace mcvo {

struct CellLogitsDecodeOptions {
  float threshold = 0.015f;  // a pixel is a candidate when its score is > threshold
  int nms_radius_px = 2;     // at network resolution; (2 r + 1)^2 window; 0: no suppression
  int border_px = 4;         // at network resolution: keep border <= x < W - border (same for y)
  int max_keypoints = 0;     // 0: no limit
};

// Decodes network outputs at network resolution (H = 8 Hc, W = 8 Wc):
//  - cell_logits: CV_32F, dims {65, Hc, Wc} (a leading batch dimension of 1
//    is accepted too); channel k < 64 is pixel (k / 8, k % 8) of the 8x8
//    cell, channel 64 "no keypoint";
//  - descriptor_map: CV_32F {D, Hc, Wc} or empty;
//  - reliability: CV_32F {1, Hc, Wc} (XFeat heatmap, already a probability) or empty.
// Softmax over the 65 channels, drop channel 64, pixel shuffle to H x W,
// score = probability (x bilinear reliability when given), threshold, border,
// then NMS among the remaining candidates (a candidate survives when no other
// candidate in its (2 r + 1)^2 window has a larger score, or an equal score
// at a smaller (y, x)), sorted by decreasing score (ties: smaller y, then x),
// capped at max_keypoints.
// Map sampling convention (descriptors and reliability): the value of cell
// (cx, cy) sits at network pixel (8 cx + 3.5, 8 cy + 3.5), so pixel (x, y)
// samples the map bilinearly at ((x - 3.5) / 8, (y - 3.5) / 8), clamped to
// the map (edge cells replicate). Descriptors are L2-normalised rows.
// Pixels are then scaled by (scale_x, scale_y) to the original image
// (x_image = (x_net + 0.5) * scale_x - 0.5, pixel centres at integers).
// Pure and deterministic.
Detections DecodeCellLogits(const cv::Mat& cell_logits, const cv::Mat& descriptor_map,
                            const cv::Mat& reliability, const CellLogitsDecodeOptions& options,
                            double scale_x, double scale_y);

enum class KeypointNetLayout {
  kXFeat,       // outputs: 65-ch keypoint logits, 64-ch feats, 1-ch heatmap
  kSuperPoint,  // outputs: 65-ch cell logits, D-ch descriptor map
};

// Which network output is which (indices into the output list).
struct KeypointNetOutputs {
  KeypointNetLayout layout = KeypointNetLayout::kXFeat;
  int cell_logits = -1;
  int descriptors = -1;
  int reliability = -1;  // XFeat only; -1 otherwise
  int descriptor_size = 0;
};

// Identifies the layout from the output names and shapes (each [1, C, Hc, Wc],
// all at the same Hc x Wc): XFeat = 65 + 1 + D channels (names
// output_keypoints / output_heatmap / output_feats decide ties), SuperPoint =
// 65 + D channels (D != 65). Anything else throws InputError
// "<file>: unsupported output layout: outputs <name [shape]>...; expected ...".
KeypointNetOutputs IdentifyLayout(const std::vector<std::string>& names,
                                  const std::vector<std::vector<int>>& shapes, const std::string& file);

// Loads an ONNX model, identifies its layout from the output shapes (and
// names), checks the input is [1, 1, H, W] with H, W multiples of 8, and runs
// one forward pass on a blank image so that a broken model fails at start-up.
// Images are resized to the model's fixed input size (cv::INTER_AREA when
// shrinking, bilinear otherwise), fed as float32 in [0, 1], and keypoints are
// mapped back to image pixels. A model with a dynamic input size gets the
// image divided by options.superpoint.downscale, rounded down to multiples of 8.
// Decoding uses options.superpoint (confidence_threshold, nms_radius_px and
// border_px at network resolution) for both layouts.
// Throws InputError "<model file>: <what is wrong>".
class KeypointNetDetector : public Detector {
 public:
  KeypointNetDetector(const std::filesystem::path& model_path, const FrontendOptions& options);
  ~KeypointNetDetector() override;
  std::string Name() const override;
  // max_candidates < 0: no limit. Descriptors: CV_32F rows, unit norm.
  Detections Detect(const cv::Mat& image, const cv::Mat& mask, int max_candidates, int border_px) override;
  int DescriptorSize() const override;
  int DescriptorType() const override;
  KeypointNetLayout layout() const;
  // The network input size; (0, 0) for a model with a dynamic input size.
  cv::Size input_size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
