// `mcvo info --rig FILE`: loads a rig.json and prints what mcvo understood
// from it (cameras, where each sits and looks in the rig frame, baselines and
// angles between optical axes), so a calibration can be checked by eye
// before a run. `mcvo info --dataset DIR` opens a dataset (any layout) and
// prints its summary (frames, time span, gaps, missing images, ground truth,
// masks, what the reader did), its rig, and which cameras see the same part
// of the world.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "command.h"
#include "dataset_args.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/dataset/overlap.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/strings.h"

namespace mcvo::tools {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

std::string Vec(const Eigen::Vector3d& v, int decimals) {
  return FormatFixed(v.x(), decimals) + " " + FormatFixed(v.y(), decimals) + " " +
         FormatFixed(v.z(), decimals);
}

// Position of the camera centre and direction of the optical axis (+z of the
// camera) in the rig frame.
Eigen::Vector3d CenterInRig(const Camera& camera) { return camera.cam_from_rig.Inverse().translation; }
Eigen::Vector3d AxisInRig(const Camera& camera) {
  return camera.cam_from_rig.rotation.conjugate() * Eigen::Vector3d::UnitZ();
}

void PrintRig(const std::string& path, const Rig& rig, std::ostream& out) {
  out << "rig: " << path << " (" << rig.NumCameras() << (rig.NumCameras() == 1 ? " camera" : " cameras")
      << "; positions in metres and directions in the rig frame)\n";
  for (int i = 0; i < rig.NumCameras(); ++i) {
    const Camera& camera = rig.cameras[static_cast<size_t>(i)];
    out << "\ncamera " << i << ": " << camera.name << "\n"
        << "  model      " << CameraModelName(camera.model) << ", " << camera.width << " x " << camera.height
        << " px\n  params    ";
    const std::vector<std::string> names = CameraModelParamNames(camera.model);
    for (size_t k = 0; k < camera.params.size(); ++k) {
      out << " " << (k < names.size() ? names[k] : "?") << "=" << FormatDouble(camera.params[k]);
    }
    out << "\n  position   " << Vec(CenterInRig(camera), 4) << "\n"
        << "  looks at   " << Vec(AxisInRig(camera), 4) << "\n";
    if (!camera.mask_path.empty()) out << "  mask       " << camera.mask_path << "\n";
  }
  if (rig.NumCameras() < 2) return;
  out << "\npairs: baseline [m], angle between optical axes [deg]\n";
  for (int i = 0; i < rig.NumCameras(); ++i) {
    for (int j = i + 1; j < rig.NumCameras(); ++j) {
      const Camera& a = rig.cameras[static_cast<size_t>(i)];
      const Camera& b = rig.cameras[static_cast<size_t>(j)];
      const double baseline = (CenterInRig(a) - CenterInRig(b)).norm();
      const double cosine = std::clamp(AxisInRig(a).dot(AxisInRig(b)), -1.0, 1.0);
      out << "  " << a.name << " - " << b.name << ": " << FormatFixed(baseline, 4) << " m, "
          << FormatFixed(std::acos(cosine) * kRadToDeg, 3) << " deg\n";
    }
  }
}

// Frame intervals longer than this many median intervals are reported as gaps.
constexpr double kGapFactor = 1.5;
// A frame is covered by ground truth when a pose lies within this time.
constexpr int64_t kGroundTruthToleranceNs = 10000000;
constexpr size_t kMaxGapsListed = 3;

std::string Seconds(int64_t t_ns) { return FormatNsAsSeconds(t_ns) + " s"; }
std::string Duration(int64_t dt_ns, int decimals = 3) {
  return FormatFixed(static_cast<double>(dt_ns) * 1e-9, decimals) + " s";
}
std::string Percent(double fraction) { return FormatFixed(100.0 * fraction, 1) + " %"; }

void PrintTiming(const DatasetIndex& index, std::ostream& out) {
  const std::vector<DatasetFrame>& frames = index.frames;
  out << "  frames     " << frames.size() << ", " << Seconds(frames.front().t_ns) << " .. "
      << Seconds(frames.back().t_ns) << " (" << Duration(frames.back().t_ns - frames.front().t_ns) << ")\n";
  if (frames.size() < 2) return;
  std::vector<int64_t> intervals;
  for (size_t i = 1; i < frames.size(); ++i) intervals.push_back(frames[i].t_ns - frames[i - 1].t_ns);
  std::vector<int64_t> sorted = intervals;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const int64_t median = sorted[sorted.size() / 2];
  // Gaps, largest first (ties: earliest first).
  std::vector<size_t> gaps;
  for (size_t i = 0; i < intervals.size(); ++i) {
    if (static_cast<double>(intervals[i]) > kGapFactor * static_cast<double>(median)) gaps.push_back(i);
  }
  std::stable_sort(gaps.begin(), gaps.end(), [&](size_t a, size_t b) { return intervals[a] > intervals[b]; });
  out << "  interval   median " << Duration(median, 4) << " ("
      << FormatFixed(1e9 / static_cast<double>(median), 2) << " Hz)\n  gaps       ";
  if (gaps.empty()) {
    out << "none (no interval > " << FormatDouble(kGapFactor) << "x median)\n";
    return;
  }
  out << gaps.size() << " interval(s) > " << FormatDouble(kGapFactor) << "x median, largest "
      << Duration(intervals[gaps.front()]) << "\n";
  for (size_t k = 0; k < std::min(gaps.size(), kMaxGapsListed); ++k) {
    const size_t i = gaps[k];
    out << "             " << Duration(intervals[i]) << " after frame " << i
        << " (t = " << Seconds(frames[i].t_ns) << ")\n";
  }
}

void PrintMissingImages(const DatasetIndex& index, std::ostream& out) {
  out << "  missing    ";
  bool any = false;
  for (int c = 0; c < index.rig.NumCameras(); ++c) {
    size_t missing = 0;
    for (const DatasetFrame& frame : index.frames)
      missing += frame.images[static_cast<size_t>(c)].empty() ? 1 : 0;
    if (missing == 0) continue;
    out << (any ? ", " : "") << index.rig.cameras[static_cast<size_t>(c)].name << ": " << missing << " ("
        << Percent(static_cast<double>(missing) / static_cast<double>(index.frames.size())) << ")";
    any = true;
  }
  out << (any ? "" : "none") << "\n";
}

void PrintGroundTruth(const DatasetIndex& index, std::ostream& out) {
  out << "  gt         ";
  if (!index.ground_truth || index.ground_truth->poses.empty()) {
    out << "none\n";
    return;
  }
  const std::vector<StampedPose>& poses = index.ground_truth->poses;
  out << poses.size() << " poses";
  if (!index.ground_truth->has_time) {
    out << " (without time stamps)\n";
    return;
  }
  std::vector<int64_t> times;
  times.reserve(poses.size());
  for (const StampedPose& pose : poses) times.push_back(pose.t_ns);
  std::sort(times.begin(), times.end());
  size_t covered = 0;
  for (const DatasetFrame& frame : index.frames) {
    const auto after = std::lower_bound(times.begin(), times.end(), frame.t_ns);
    const bool near_after = after != times.end() && *after - frame.t_ns <= kGroundTruthToleranceNs;
    const bool near_before = after != times.begin() && frame.t_ns - *(after - 1) <= kGroundTruthToleranceNs;
    covered += near_after || near_before ? 1 : 0;
  }
  out << ", " << Seconds(times.front()) << " .. " << Seconds(times.back()) << " ("
      << Duration(times.back() - times.front()) << "); "
      << Percent(static_cast<double>(covered) / static_cast<double>(index.frames.size()))
      << " of frames have a pose within " << kGroundTruthToleranceNs / 1000000 << " ms\n";
}

void PrintMasks(const DatasetIndex& index, std::ostream& out) {
  out << "  masks      ";
  bool any = false;
  for (size_t c = 0; c < index.masks.size(); ++c) {
    const cv::Mat& mask = index.masks[c];
    if (mask.empty()) continue;
    out << (any ? ", " : "") << index.rig.cameras[c].name << " ("
        << Percent(static_cast<double>(cv::countNonZero(mask)) / static_cast<double>(mask.total()))
        << " valid)";
    any = true;
  }
  out << (any ? "" : "none (every pixel valid)") << "\n";
}

void PrintOverlap(const Rig& rig, const std::vector<cv::Mat>& masks, std::ostream& out) {
  if (rig.NumCameras() < 2) return;
  out << "\nview overlap at " << FormatDouble(kViewOverlapDepthM)
      << " m, masks applied (a - b: share of a's view that b sees / of b's view that a sees)\n";
  bool any = false;
  for (int i = 0; i < rig.NumCameras(); ++i) {
    for (int j = i + 1; j < rig.NumCameras(); ++j) {
      const Camera& a = rig.cameras[static_cast<size_t>(i)];
      const Camera& b = rig.cameras[static_cast<size_t>(j)];
      const cv::Mat& mask_a = masks[static_cast<size_t>(i)];
      const cv::Mat& mask_b = masks[static_cast<size_t>(j)];
      const double ab = ViewOverlap(a, b, kViewOverlapDepthM, mask_a, mask_b);
      const double ba = ViewOverlap(b, a, kViewOverlapDepthM, mask_b, mask_a);
      if (ab <= 0.0 && ba <= 0.0) continue;
      out << "  " << a.name << " - " << b.name << ": " << Percent(ab) << " / " << Percent(ba) << "\n";
      any = true;
    }
  }
  if (!any)
    out << "  none: no two cameras see the same point at " << FormatDouble(kViewOverlapDepthM) << " m\n";
}

void PrintDataset(const DatasetIndex& index, std::ostream& out) {
  out << "dataset: " << index.root.string() << "\n"
      << "  format     " << index.format << "\n"
      << "  name       " << index.name << "\n";
  PrintTiming(index, out);
  PrintMissingImages(index, out);
  PrintGroundTruth(index, out);
  PrintMasks(index, out);
  if (!index.log.empty()) {
    out << "\nreader:\n";
    for (const std::string& line : index.log) out << "  " << line << "\n";
  }
  out << "\n";
  PrintRig("of the " + index.format + " dataset", index.rig, out);
  PrintOverlap(index.rig, index.masks, out);
}

// --decode: every image of the dataset decoded as `mcvo run` decodes them
// (FrameStream on `threads` threads), the wall time and throughput printed.
// An unreadable image stops it with the InputError naming the file.
void DecodeAll(const DatasetIndex& index, int threads, std::ostream& out) {
  FrameStreamOptions options;
  options.threads = ResolveThreads(threads);
  const auto start = std::chrono::steady_clock::now();
  FrameStream stream(index, options);
  int frames = 0, images = 0;
  double megapixels = 0.0;
  while (std::optional<FrameImages> frame = stream.Next()) {
    ++frames;
    for (const cv::Mat& image : frame->images) {
      if (image.empty()) continue;
      ++images;
      megapixels += image.total() / 1e6;
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out << "\ndecode: " << frames << " frames, " << images << " images (" << FormatFixed(megapixels, 1)
      << " Mpx) in " << FormatFixed(seconds, 3) << " s on " << options.threads
      << " threads: " << FormatFixed(frames / std::max(seconds, 1e-9), 2) << " frames/s, "
      << FormatFixed(megapixels / std::max(seconds, 1e-9), 1) << " Mpx/s (wall clock)\n";
}

int RunInfo(int argc, const char* const* argv) {
  std::string rig_path;
  DatasetArgs dataset;
  bool decode = false;
  int threads = 0;
  ArgParser args("mcvo info", "Loads a rig or a dataset and prints what mcvo understood from it.");
  args.AddString("rig", &rig_path, "FILE", "rig.json to load and describe (docs/rig-json.md)");
  AddDatasetArgs(&args, &dataset, /*dataset_required=*/false);
  args.AddFlag("decode", &decode,
               "also decode every image as mcvo run does and print the time (checks that all images read)");
  args.AddInt("threads", &threads, "decoding threads for --decode; 0: all cores");
  args.AddEpilog(
      "examples: mcvo info --rig config/rigs/kitti360.json\n"
      "          mcvo info --dataset KITTI-360 --sequence 2013_05_28_drive_0000_sync\n"
      "          mcvo info --dataset KITTI/dataset --sequence 06 --cameras image_02,image_03\n"
      "          mcvo info --dataset seq/kitti360 --decode --threads 2\n"
      "          mcvo info --dataset multicam.bag --calib camchain.yaml   (ROS bag: topics, counts, rates)\n");
  if (!args.Parse(argc, argv)) return kExitOk;
  if (!rig_path.empty() && !dataset.root.empty())
    throw UsageError("give either --rig or --dataset, not both");
  if (rig_path.empty() && dataset.root.empty()) {
    throw UsageError("nothing to describe: give --rig FILE or --dataset DIR (see --help)");
  }
  if (threads < 0) throw UsageError("--threads: must be >= 0");
  if (!decode && args.WasGiven("threads")) throw UsageError("--threads needs --decode");
  if (!rig_path.empty()) {
    if (decode) throw UsageError("--decode needs --dataset");
    for (const char* dataset_flag : kDatasetDetailFlags) {
      if (args.WasGiven(dataset_flag)) throw UsageError(StrCat("--", dataset_flag, " needs --dataset"));
    }
    const Rig rig = ReadRig(rig_path);
    PrintRig(rig_path, rig, std::cout);
    return kExitOk;
  }
  const DatasetIndex index = OpenDataset(MakeDatasetOptions(dataset));
  PrintDataset(index, std::cout);
  if (decode) DecodeAll(index, threads, std::cout);
  return kExitOk;
}

const CommandRegistrar kRegistrar(
    "info", {"describe a rig.json or a dataset (cameras, baselines, frames, gaps, overlap)", RunInfo});

}  // namespace
}  // namespace mcvo::tools
