// Pure decoding of keypoint-network outputs (DecodeCellLogits) and the
// output-layout check (IdentifyLayout); see keypoint_net.h.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "mcvo/frontend/keypoint_net.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr int kCell = 8;
constexpr int kCellChannels = kCell * kCell + 1;  // 64 pixels + "no keypoint"

// A CV_32F map {C, Hc, Wc}, or {1, C, Hc, Wc}, viewed as planes.
struct MapView {
  const float* data = nullptr;
  int channels = 0, rows = 0, cols = 0;

  const float* Plane(int c) const { return data + static_cast<size_t>(c) * rows * cols; }
};

MapView View(const cv::Mat& map) {
  MCVO_CHECK_MSG(map.type() == CV_32F && map.isContinuous(), "network outputs must be continuous CV_32F");
  MCVO_CHECK_MSG(map.dims == 3 || (map.dims == 4 && map.size[0] == 1), "expected {C, Hc, Wc}, got ", map.dims,
                 " dims");
  const int off = map.dims - 3;
  return {map.ptr<float>(), map.size[off], map.size[off + 1], map.size[off + 2]};
}

// Bilinear sampling position of network pixel (x, y) in a 1/8 map whose cell
// values sit at 8 c + 3.5 (clamped to the map).
struct Bilinear {
  int x0, y0, x1, y1;
  float wx, wy;
};

Bilinear BilinearAt(float x, float y, int cols, int rows) {
  const float u = std::clamp((x - 3.5f) / kCell, 0.0f, static_cast<float>(cols - 1));
  const float v = std::clamp((y - 3.5f) / kCell, 0.0f, static_cast<float>(rows - 1));
  Bilinear b;
  b.x0 = static_cast<int>(std::floor(u));
  b.y0 = static_cast<int>(std::floor(v));
  b.x1 = std::min(b.x0 + 1, cols - 1);
  b.y1 = std::min(b.y0 + 1, rows - 1);
  b.wx = u - static_cast<float>(b.x0);
  b.wy = v - static_cast<float>(b.y0);
  return b;
}

float Sample(const float* plane, int cols, const Bilinear& b) {
  const float top = (1.0f - b.wx) * plane[b.y0 * cols + b.x0] + b.wx * plane[b.y0 * cols + b.x1];
  const float bottom = (1.0f - b.wx) * plane[b.y1 * cols + b.x0] + b.wx * plane[b.y1 * cols + b.x1];
  return (1.0f - b.wy) * top + b.wy * bottom;
}

std::string ShapeString(const std::vector<int>& shape) {
  std::ostringstream out;
  out << "[";
  for (size_t i = 0; i < shape.size(); ++i) out << (i ? "," : "") << shape[i];
  out << "]";
  return out.str();
}

}  // namespace

Detections DecodeCellLogits(const cv::Mat& cell_logits, const cv::Mat& descriptor_map,
                            const cv::Mat& reliability, const CellLogitsDecodeOptions& options,
                            double scale_x, double scale_y) {
  const MapView logits = View(cell_logits);
  MCVO_CHECK_MSG(logits.channels == kCellChannels, "cell logits need 65 channels, got ", logits.channels);
  const int hc = logits.rows, wc = logits.cols;
  const int height = hc * kCell, width = wc * kCell;
  MapView rel;
  if (!reliability.empty()) {
    rel = View(reliability);
    MCVO_CHECK(rel.channels == 1 && rel.rows == hc && rel.cols == wc);
  }
  MapView desc;
  if (!descriptor_map.empty()) {
    desc = View(descriptor_map);
    MCVO_CHECK(desc.rows == hc && desc.cols == wc && desc.channels > 0);
  }

  // Softmax over the 65 channels of each cell (max subtracted for range),
  // pixel shuffle: channel k -> pixel (8 cy + k / 8, 8 cx + k % 8).
  // Non-candidates keep -1 (all scores are >= 0).
  cv::Mat1f score(height, width, -1.0f);
  std::vector<float> e(kCellChannels);
  for (int cy = 0; cy < hc; ++cy) {
    for (int cx = 0; cx < wc; ++cx) {
      const int cell = cy * wc + cx;
      float max_logit = -INFINITY;
      for (int k = 0; k < kCellChannels; ++k) max_logit = std::max(max_logit, logits.Plane(k)[cell]);
      double sum = 0.0;
      for (int k = 0; k < kCellChannels; ++k) {
        e[k] = std::exp(logits.Plane(k)[cell] - max_logit);
        sum += e[k];
      }
      for (int k = 0; k < kCellChannels - 1; ++k) {
        const int x = cx * kCell + k % kCell, y = cy * kCell + k / kCell;
        if (x < options.border_px || y < options.border_px || x >= width - options.border_px ||
            y >= height - options.border_px)
          continue;
        float s = static_cast<float>(e[k] / sum);
        if (rel.data != nullptr)
          s *= Sample(rel.Plane(0), wc, BilinearAt(static_cast<float>(x), static_cast<float>(y), wc, hc));
        if (s > options.threshold) score(y, x) = s;
      }
    }
  }

  // NMS among the candidates, ties broken by position (raster order wins).
  struct Candidate {
    int x, y;
    float s;
  };
  std::vector<Candidate> kept;
  const int r = std::max(0, options.nms_radius_px);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float s = score(y, x);
      if (s < 0.0f) continue;
      bool is_max = true;
      for (int yy = std::max(0, y - r); yy <= std::min(height - 1, y + r) && is_max; ++yy) {
        for (int xx = std::max(0, x - r); xx <= std::min(width - 1, x + r); ++xx) {
          const float o = score(yy, xx);
          if (o > s || (o == s && (yy < y || (yy == y && xx < x)))) {
            is_max = false;
            break;
          }
        }
      }
      if (is_max) kept.push_back({x, y, s});
    }
  }
  // Raster order already breaks ties by (y, x); a stable sort keeps it.
  std::stable_sort(kept.begin(), kept.end(),
                   [](const Candidate& a, const Candidate& b) { return a.s > b.s; });
  if (options.max_keypoints > 0 && kept.size() > static_cast<size_t>(options.max_keypoints))
    kept.resize(options.max_keypoints);

  Detections out;
  out.pixels.reserve(kept.size());
  out.scores.reserve(kept.size());
  if (desc.data != nullptr) out.descriptors = cv::Mat(static_cast<int>(kept.size()), desc.channels, CV_32F);
  for (size_t i = 0; i < kept.size(); ++i) {
    const Candidate& c = kept[i];
    out.pixels.emplace_back(static_cast<float>((c.x + 0.5) * scale_x - 0.5),
                            static_cast<float>((c.y + 0.5) * scale_y - 0.5));
    out.scores.push_back(c.s);
    if (desc.data == nullptr) continue;
    const Bilinear b = BilinearAt(static_cast<float>(c.x), static_cast<float>(c.y), wc, hc);
    float* row = out.descriptors.ptr<float>(static_cast<int>(i));
    double norm2 = 0.0;
    for (int d = 0; d < desc.channels; ++d) {
      row[d] = Sample(desc.Plane(d), wc, b);
      norm2 += static_cast<double>(row[d]) * row[d];
    }
    const float inv = norm2 > 0.0 ? static_cast<float>(1.0 / std::sqrt(norm2)) : 0.0f;
    for (int d = 0; d < desc.channels; ++d) row[d] *= inv;
  }
  return out;
}

KeypointNetOutputs IdentifyLayout(const std::vector<std::string>& names,
                                  const std::vector<std::vector<int>>& shapes, const std::string& file) {
  MCVO_CHECK(names.size() == shapes.size());
  std::ostringstream listing;
  for (size_t i = 0; i < names.size(); ++i)
    listing << (i ? ", " : "") << names[i] << " " << ShapeString(shapes[i]);
  const auto fail = [&](const std::string& why) {
    MCVO_THROW_INPUT(
        file, ": unsupported output layout: outputs ", listing.str(), why,
        "; expected XFeat (output_keypoints [1,65,H/8,W/8] cell logits, output_feats [1,64,H/8,W/8] "
        "descriptors, output_heatmap [1,1,H/8,W/8] reliability) or SuperPoint (a [1,65,H/8,W/8] cell-"
        "logit map and a [1,D,H/8,W/8] descriptor map)");
  };
  if (names.empty()) fail(" (none)");
  for (const auto& shape : shapes) {
    if (shape.size() != 4 || shape[0] != 1 || shape[1] < 1 || shape[2] < 1 || shape[3] < 1)
      fail(" (each output must be [1,C,Hc,Wc])");
    if (shape[2] != shapes[0][2] || shape[3] != shapes[0][3]) fail(" (outputs differ in resolution)");
  }
  const auto find = [&](const char* name) -> int {
    const auto it = std::find(names.begin(), names.end(), name);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
  };
  const auto with_channels = [&](int channels, int skip) {
    std::vector<int> found;
    for (size_t i = 0; i < shapes.size(); ++i)
      if (shapes[i][1] == channels && static_cast<int>(i) != skip) found.push_back(static_cast<int>(i));
    return found;
  };

  KeypointNetOutputs out;
  if (shapes.size() == 3) {
    out.layout = KeypointNetLayout::kXFeat;
    out.cell_logits = find("output_keypoints");
    out.reliability = find("output_heatmap");
    out.descriptors = find("output_feats");
    if (out.cell_logits < 0 || out.reliability < 0 || out.descriptors < 0) {  // by channel counts
      const std::vector<int> logits = with_channels(kCellChannels, -1);
      const std::vector<int> heat = with_channels(1, -1);
      if (logits.size() != 1 || heat.size() != 1) fail("");
      out.cell_logits = logits[0];
      out.reliability = heat[0];
      out.descriptors = 3 - logits[0] - heat[0];
    }
    if (shapes[out.cell_logits][1] != kCellChannels || shapes[out.reliability][1] != 1) fail("");
  } else if (shapes.size() == 2) {
    out.layout = KeypointNetLayout::kSuperPoint;
    const std::vector<int> logits = with_channels(kCellChannels, -1);
    if (logits.size() != 1) fail("");
    out.cell_logits = logits[0];
    out.descriptors = 1 - logits[0];
  } else {
    fail("");
  }
  out.descriptor_size = shapes[out.descriptors][1];
  return out;
}

}  // namespace mcvo
