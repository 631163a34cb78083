// KeypointNetDetector: an ONNX keypoint network run with OpenCV DNN on the
// CPU (see keypoint_net.h). The pure decoder is in cell_logits.cc.
#include "mcvo/frontend/keypoint_net.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include "classic_detectors.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

// Minimal protobuf reader, enough to find the declared shape of the first
// graph input of an ONNX model (OpenCV 4.6 offers no query for it):
// ModelProto.graph = 7, GraphProto.input = 11, GraphProto.initializer = 5,
// ValueInfoProto.name = 1 / .type = 2, TypeProto.tensor_type = 1,
// Tensor.shape = 2, TensorShapeProto.dim = 1, Dimension.dim_value = 1
// (a dim_param or a missing value means dynamic: -1).
class ProtoReader {
 public:
  ProtoReader(const char* begin, const char* end) : p_(begin), end_(end) {}
  bool Done() const { return p_ >= end_; }
  // Reads one field; for length-delimited fields (wire type 2) `sub` is its
  // payload, for varints `value`. False on malformed data.
  bool Next(int* field, ProtoReader* sub, uint64_t* value) {
    uint64_t key = 0;
    if (!Varint(&key)) return false;
    *field = static_cast<int>(key >> 3);
    switch (key & 7) {
      case 0:
        return Varint(value);
      case 1:
        return Skip(8);
      case 5:
        return Skip(4);
      case 2: {
        uint64_t length = 0;
        if (!Varint(&length) || length > static_cast<uint64_t>(end_ - p_)) return false;
        *sub = ProtoReader(p_, p_ + length);
        p_ += length;
        return true;
      }
      default:
        return false;
    }
  }
  std::string Text() const { return std::string(p_, end_); }

 private:
  bool Varint(uint64_t* value) {
    *value = 0;
    for (int shift = 0; shift < 64 && p_ < end_; shift += 7) {
      const auto byte = static_cast<uint8_t>(*p_++);
      *value |= static_cast<uint64_t>(byte & 0x7f) << shift;
      if ((byte & 0x80) == 0) return true;
    }
    return false;
  }
  bool Skip(size_t n) {
    if (static_cast<size_t>(end_ - p_) < n) return false;
    p_ += n;
    return true;
  }
  const char* p_;
  const char* end_;
};

// Finds the repeated sub-messages `field` of `message`.
std::vector<ProtoReader> SubMessages(ProtoReader message, int field) {
  std::vector<ProtoReader> found;
  int f = 0;
  uint64_t v = 0;
  ProtoReader sub(nullptr, nullptr);
  while (!message.Done()) {
    if (!message.Next(&f, &sub, &v)) return {};
    if (f == field) found.push_back(sub);
  }
  return found;
}

std::string NameOf(ProtoReader message, int field) {
  const std::vector<ProtoReader> names = SubMessages(message, field);
  return names.empty() ? std::string() : names.front().Text();
}

// Shape of the first graph input that is not an initializer; empty when the
// file does not declare one.
std::vector<int64_t> OnnxInputShape(const std::string& bytes) {
  const std::vector<ProtoReader> graphs =
      SubMessages(ProtoReader(bytes.data(), bytes.data() + bytes.size()), 7);
  if (graphs.empty()) return {};
  std::vector<std::string> initializers;
  for (const ProtoReader& tensor : SubMessages(graphs.front(), 5)) initializers.push_back(NameOf(tensor, 8));
  for (const ProtoReader& input : SubMessages(graphs.front(), 11)) {
    if (std::find(initializers.begin(), initializers.end(), NameOf(input, 1)) != initializers.end()) continue;
    std::vector<int64_t> shape;
    for (const ProtoReader& type : SubMessages(input, 2))
      for (const ProtoReader& tensor : SubMessages(type, 1))
        for (const ProtoReader& dims : SubMessages(tensor, 2))
          for (ProtoReader dim : SubMessages(dims, 1)) {
            int64_t value = -1;
            int f = 0;
            uint64_t v = 0;
            ProtoReader sub(nullptr, nullptr);
            while (!dim.Done() && dim.Next(&f, &sub, &v))
              if (f == 1) value = static_cast<int64_t>(v) > 0 ? static_cast<int64_t>(v) : -1;
            shape.push_back(value);
          }
    return shape;
  }
  return {};
}

cv::Mat MakeBlob(const cv::Mat& grey_u8) {
  const int dims[] = {1, 1, grey_u8.rows, grey_u8.cols};
  cv::Mat blob(4, dims, CV_32F);
  cv::Mat plane(grey_u8.rows, grey_u8.cols, CV_32F, blob.ptr<float>());
  grey_u8.convertTo(plane, CV_32F, 1.0 / 255.0);
  return blob;
}

std::vector<int> ShapeOf(const cv::Mat& m) { return std::vector<int>(m.size.p, m.size.p + m.dims); }

}  // namespace

struct KeypointNetDetector::Impl {
  std::string file;
  cv::dnn::Net net;
  std::vector<std::string> output_names;
  KeypointNetOutputs outputs;
  cv::Size input_size;  // (0, 0): dynamic
  int downscale = 1;
  CellLogitsDecodeOptions decode;

  // The network input size for an image of `image_size`.
  cv::Size NetSize(const cv::Size& image_size) const {
    if (input_size.area() > 0) return input_size;
    return {std::max(kMinSide, image_size.width / downscale / 8 * 8),
            std::max(kMinSide, image_size.height / downscale / 8 * 8)};
  }
  std::vector<cv::Mat> Forward(const cv::Mat& grey_u8) {
    net.setInput(MakeBlob(grey_u8));
    std::vector<cv::Mat> results;
    net.forward(results, output_names);
    return results;
  }
  static constexpr int kMinSide = 16;
};

KeypointNetDetector::KeypointNetDetector(const std::filesystem::path& model_path,
                                         const FrontendOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.file = model_path.string();
  m.downscale = std::max(1, options.superpoint.downscale);
  m.decode.threshold = static_cast<float>(options.superpoint.confidence_threshold);
  m.decode.nms_radius_px = options.superpoint.nms_radius_px;
  m.decode.border_px = options.superpoint.border_px;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(model_path, ec)) MCVO_THROW_INPUT(m.file, ": no such file");

  const std::vector<int64_t> declared = OnnxInputShape(ReadFileToString(model_path));
  try {
    m.net = cv::dnn::readNetFromONNX(m.file);
  } catch (const cv::Exception& e) {
    MCVO_THROW_INPUT(m.file, ": cannot load ONNX model: ", e.err.empty() ? e.what() : e.err);
  }
  if (m.net.empty()) MCVO_THROW_INPUT(m.file, ": cannot load ONNX model: empty network");
  m.net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  m.net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  m.output_names = m.net.getUnconnectedOutLayersNames();

  if (!declared.empty()) {
    if (declared.size() != 4 || (declared[0] != 1 && declared[0] != -1) ||
        (declared[1] != 1 && declared[1] != -1))
      MCVO_THROW_INPUT(m.file, ": unsupported input: expected [1,1,H,W] (one grey image), got ",
                       declared.size(), " dims");
    if (declared[2] > 0 && declared[3] > 0) {
      // A declared size beyond any camera image is a corrupt or foreign model,
      // not a size to allocate.
      if (declared[2] > 16384 || declared[3] > 16384)
        MCVO_THROW_INPUT(m.file, ": unsupported input size ", declared[3], "x", declared[2],
                         ": larger than 16384 px");
      if (declared[2] % 8 != 0 || declared[3] % 8 != 0)
        MCVO_THROW_INPUT(m.file, ": unsupported input size ", declared[3], "x", declared[2],
                         ": width and height must be multiples of 8");
      m.input_size = cv::Size(static_cast<int>(declared[3]), static_cast<int>(declared[2]));
    }
  }

  // A blank forward pass: checks the model runs and gives the output shapes.
  const cv::Size probe = m.input_size.area() > 0 ? m.input_size : cv::Size(320, 240);
  std::vector<cv::Mat> results;
  try {
    results = m.Forward(cv::Mat(probe, CV_8UC1, cv::Scalar(0)));
  } catch (const cv::Exception& e) {
    MCVO_THROW_INPUT(m.file, ": forward pass on a blank ", probe.width, "x", probe.height,
                     " image failed: ", e.err.empty() ? e.what() : e.err);
  }
  std::vector<std::vector<int>> shapes;
  shapes.reserve(results.size());
  for (const cv::Mat& r : results) shapes.push_back(ShapeOf(r));
  m.outputs = IdentifyLayout(m.output_names, shapes, m.file);
  const std::vector<int>& logits = shapes[m.outputs.cell_logits];
  if (logits[2] * 8 != probe.height || logits[3] * 8 != probe.width)
    MCVO_THROW_INPUT(m.file, ": outputs at ", logits[3], "x", logits[2], " for a ", probe.width, "x",
                     probe.height, " input; expected 1/8 resolution");
}

KeypointNetDetector::~KeypointNetDetector() = default;

std::string KeypointNetDetector::Name() const {
  const char* kind = impl_->outputs.layout == KeypointNetLayout::kXFeat ? "xfeat" : "superpoint";
  return StrCat(kind, "(", std::filesystem::path(impl_->file).filename().string(), ")");
}

int KeypointNetDetector::DescriptorSize() const { return impl_->outputs.descriptor_size; }
int KeypointNetDetector::DescriptorType() const { return CV_32F; }
KeypointNetLayout KeypointNetDetector::layout() const { return impl_->outputs.layout; }
cv::Size KeypointNetDetector::input_size() const { return impl_->input_size; }

Detections KeypointNetDetector::Detect(const cv::Mat& image, const cv::Mat& mask, int max_candidates,
                                       int border_px) {
  Impl& m = *impl_;
  MCVO_CHECK_MSG(image.type() == CV_8UC1 && !image.empty(), "Detect needs a non-empty CV_8UC1 image");
  MCVO_CHECK(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == image.size()));
  const cv::Size net_size = m.NetSize(image.size());
  cv::Mat net_image = image;
  if (net_size != image.size()) {
    const bool shrink = net_size.width <= image.cols && net_size.height <= image.rows;
    cv::resize(image, net_image, net_size, 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
  }
  const std::vector<cv::Mat> results = m.Forward(net_image);
  const cv::Mat empty;
  Detections all = DecodeCellLogits(results[m.outputs.cell_logits], results[m.outputs.descriptors],
                                    m.outputs.reliability >= 0 ? results[m.outputs.reliability] : empty,
                                    m.decode, static_cast<double>(image.cols) / net_size.width,
                                    static_cast<double>(image.rows) / net_size.height);

  // Mask and image border, then the cap with its spread extras, as the
  // Shi-Tomasi detector does (CapWithSpreadExtras).
  Detections out;
  std::vector<int> admissible;
  std::vector<Eigen::Vector2f> admissible_pixels;
  std::vector<float> admissible_scores;
  const float lo = static_cast<float>(std::max(0, border_px));
  for (size_t i = 0; i < all.size(); ++i) {
    const Eigen::Vector2f& p = all.pixels[i];
    if (p.x() < lo || p.y() < lo || p.x() > image.cols - 1 - lo || p.y() > image.rows - 1 - lo) continue;
    if (!mask.empty()) {
      const int x = std::clamp(cvRound(p.x()), 0, image.cols - 1),
                y = std::clamp(cvRound(p.y()), 0, image.rows - 1);
      if (mask.at<uint8_t>(y, x) == 0) continue;
    }
    admissible.push_back(static_cast<int>(i));
    admissible_pixels.push_back(p);
    admissible_scores.push_back(all.scores[i]);
  }
  const int cap = max_candidates >= 0 ? max_candidates : static_cast<int>(admissible.size());
  std::vector<int> keep;
  for (int k : internal::CapWithSpreadExtras(admissible_pixels, admissible_scores, cap, image.cols, image.rows)) {
    keep.push_back(admissible[static_cast<size_t>(k)]);
  }
  out.pixels.reserve(keep.size());
  out.scores.reserve(keep.size());
  out.descriptors = cv::Mat(static_cast<int>(keep.size()), DescriptorSize(), CV_32F);
  for (size_t j = 0; j < keep.size(); ++j) {
    out.pixels.push_back(all.pixels[keep[j]]);
    out.scores.push_back(all.scores[keep[j]]);
    all.descriptors.row(keep[j]).copyTo(out.descriptors.row(static_cast<int>(j)));
  }
  return out;
}

}  // namespace mcvo
