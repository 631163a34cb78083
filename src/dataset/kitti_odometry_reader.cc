// KITTI odometry reader: a sequence as the benchmark ships it, read in place
// (docs/datasets.md, "KITTI odometry"):
//
//   <root>/sequences/NN/calib.txt            P0: .. P3: (3x4 row-major), Tr:
//   <root>/sequences/NN/times.txt            seconds, line i = frame i
//   <root>/sequences/NN/image_K/NNNNNN.png   K = 0, 1 (grey), 2, 3 (colour)
//   <root>/poses/NN.txt                      optional, world_from_cam0 per frame
//
// <root> is the KITTI root (with --sequence NN, or one sequence only) or the
// sequence folder itself (ground truth at ../../poses/NN.txt). Cameras are
// named image_00 .. image_03 (folders image_0 .. image_3), as the KITTI-360
// rectified pair and config/kitti360_2cam.json. Every P_i = K_i [I | t_i] of
// the rectified rig: the rig frame is camera 0, so the ground truth is
// world_from_rig as it is and cam_from_rig of camera i is the translation
// t_i - t_0, t_i = K_i^-1 P_i[:, 3].
#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mcvo/dataset/dataset.h"
#include "mcvo/dataset/image_file.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
using Matrix34d = Eigen::Matrix<double, 3, 4, Eigen::RowMajor>;

constexpr int kNumCameras = 4;

bool IsDirectory(const fs::path& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

bool IsFile(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

// "image_00" for KITTI's folder image_0.
std::string CameraName(int k) { return StrCat("image_0", k); }
std::string FolderName(int k) { return StrCat("image_", k); }

// The camera number of a name (image_00 .. image_03), or -1.
int CameraIndex(const std::string& name) {
  for (int k = 0; k < kNumCameras; ++k)
    if (name == CameraName(k)) return k;
  return -1;
}

// Where the sequence is and what it is called.
struct SequencePaths {
  std::string name;  // "06"
  fs::path folder;   // .../sequences/06
  fs::path poses;    // .../poses/06.txt (may not exist)
};

SequencePaths ResolveSequence(const DatasetOptions& options, std::vector<std::string>* log) {
  const fs::path& root = options.root;
  if (!IsDirectory(root)) MCVO_THROW_INPUT(root.string(), ": dataset folder ", WhyNotAFolder(root));
  SequencePaths out;
  const fs::path sequences = root / "sequences";
  if (IsFile(root / "calib.txt") || !IsDirectory(sequences)) {
    // The sequence folder itself.
    fs::path folder = fs::absolute(root).lexically_normal();
    if (folder.filename().empty()) folder = folder.parent_path();
    out.name = folder.filename().string();
    if (!options.sequence.empty() && options.sequence != out.name) {
      throw UsageError(StrCat("sequence: ", root.string(), " is the KITTI odometry sequence ", out.name,
                              " itself, not '", options.sequence, "'"));
    }
    out.folder = root;
    out.poses = root / ".." / ".." / "poses" / (out.name + ".txt");
    return out;
  }
  if (!options.sequence.empty()) {
    out.name = options.sequence;
  } else {
    std::vector<std::string> names;
    std::error_code ec;
    for (const fs::directory_entry& entry : fs::directory_iterator(sequences, ec)) {
      if (entry.is_directory(ec)) names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    if (names.size() != 1) {
      std::string list;
      for (const std::string& name : names) list += (list.empty() ? "" : ", ") + name;
      throw UsageError(StrCat("sequence: not given, and ", sequences.string(), " holds ", names.size(),
                              " sequences (", list, "); give --sequence"));
    }
    out.name = names.front();
    log->push_back(StrCat("sequence: ", out.name, " (the only one in ", sequences.string(), ")"));
  }
  out.folder = sequences / out.name;
  if (!IsDirectory(out.folder)) MCVO_THROW_INPUT(out.folder.string(), ": sequence folder does not exist");
  out.poses = root / "poses" / (out.name + ".txt");
  return out;
}

// calib.txt: P0 .. P3 (those present) and whether Tr was there.
struct Calibration {
  std::array<std::optional<Matrix34d>, kNumCameras> p;
  bool has_tr = false;
};

// Twelve finite numbers of a calib.txt line, or an InputError naming it.
Matrix34d ParseTwelve(const std::vector<std::string_view>& fields, const std::string& where,
                      const std::string& key) {
  if (fields.size() != 12) {
    MCVO_THROW_INPUT(where, ": ", key, ": expected 12 numbers (3x4 row-major), got ", fields.size(),
                     " fields");
  }
  Matrix34d m;
  for (int i = 0; i < 12; ++i) {
    const std::optional<double> value = ParseDouble(fields[static_cast<size_t>(i)]);
    if (!value || !std::isfinite(*value)) {
      MCVO_THROW_INPUT(where, ": ", key, ": field ", i + 1, " '", fields[static_cast<size_t>(i)],
                       "' is not a finite number");
    }
    m(i / 4, i % 4) = *value;
  }
  return m;
}

// The official "KEY: 12 numbers" lines (P0..P3, Tr; Tr_velo_to_cam is taken
// as Tr; other keys are logged and not used), or, when no line has a key,
// unkeyed lines in the official order P0, P1, P2, P3, Tr.
Calibration ReadCalibration(const fs::path& path, std::vector<std::string>* log) {
  if (!IsFile(path)) MCVO_THROW_INPUT(path.string(), ": missing calibration file (", WhyNotAFile(path), ")");
  const std::string content = ReadFileToString(path);
  struct Line {
    int number = 0;
    std::string key;  // empty: no key
    std::vector<std::string_view> fields;
  };
  std::vector<Line> lines;
  int number = 0;
  size_t start = 0;
  while (start < content.size()) {
    size_t end = content.find('\n', start);
    if (end == std::string::npos) end = content.size();
    const std::string_view text = Trim(std::string_view(content).substr(start, end - start));
    start = end + 1;
    ++number;
    if (text.empty()) continue;
    Line line;
    line.number = number;
    std::string_view values = text;
    const size_t colon = text.find(':');
    if (colon != std::string_view::npos) {
      line.key = std::string(Trim(text.substr(0, colon)));
      values = text.substr(colon + 1);
    }
    line.fields = SplitTokens(values);
    lines.push_back(std::move(line));
  }
  const bool keyed = std::any_of(lines.begin(), lines.end(), [](const Line& l) { return !l.key.empty(); });
  if (!keyed && lines.size() > kNumCameras + 1) {
    MCVO_THROW_INPUT(path.string(), ":", lines[kNumCameras + 1].number, ": ", lines.size(),
                     " lines without 'P0:'-style keys: only P0, P1, P2, P3, Tr can be told apart by order");
  }
  Calibration calibration;
  for (size_t i = 0; i < lines.size(); ++i) {
    const Line& line = lines[i];
    const std::string where = StrCat(path.string(), ":", line.number);
    if (keyed && line.key.empty()) {
      MCVO_THROW_INPUT(where,
                       ": expected 'P0: 12 numbers' (a key before the numbers; other lines have keys)");
    }
    const std::string key = keyed ? line.key : (i < kNumCameras ? StrCat("P", i) : std::string("Tr"));
    if (key == "Tr" || key == "Tr_velo_to_cam") {
      if (calibration.has_tr) MCVO_THROW_INPUT(where, ": ", key, ": given twice");
      ParseTwelve(line.fields, where, key);  // validated; the velodyne is not used
      calibration.has_tr = true;
      continue;
    }
    const int k = key.size() == 2 && key[0] == 'P' ? key[1] - '0' : -1;
    if (k < 0 || k >= kNumCameras) {
      log->push_back(StrCat(where, ": key '", key, "' not used"));
      continue;
    }
    if (calibration.p[static_cast<size_t>(k)]) MCVO_THROW_INPUT(where, ": ", key, ": given twice");
    calibration.p[static_cast<size_t>(k)] = ParseTwelve(line.fields, where, key);
  }
  if (!keyed)
    log->push_back(StrCat(path.string(), ": lines without keys, read in the order P0, P1, P2, P3, Tr"));
  if (!calibration.p[0]) MCVO_THROW_INPUT(path.string(), ": missing P0 (camera 0 defines the rig frame)");
  return calibration;
}

// K and t of P = K [I | t]. Throws when the left 3x3 is not a pinhole K
// (zero skew, last row 0 0 1).
void SplitProjection(const Matrix34d& p, const std::string& where, Eigen::Matrix3d* k, Eigen::Vector3d* t) {
  *k = p.leftCols<3>();
  const double fx = (*k)(0, 0), fy = (*k)(1, 1);
  if (!(fx > 0.0 && fy > 0.0))
    MCVO_THROW_INPUT(where, ": focal lengths must be > 0 (P[0,0] = ", FormatDouble(fx),
                     ", P[1,1] = ", FormatDouble(fy), ")");
  if ((*k)(0, 1) != 0.0) MCVO_THROW_INPUT(where, ": skew P[0,1] = ", FormatDouble((*k)(0, 1)), " is not 0");
  if ((*k)(1, 0) != 0.0 || (*k)(2, 0) != 0.0 || (*k)(2, 1) != 0.0 || (*k)(2, 2) != 1.0) {
    MCVO_THROW_INPUT(where,
                     ": the left 3x3 of P is not a rectified pinhole K (expected P[1,0] = P[2,0] = "
                     "P[2,1] = 0 and P[2,2] = 1)");
  }
  // t = K^-1 P[:, 3] by back substitution (upper triangular K): exactly
  // P[0,3] / fx for a pure x baseline.
  const double tz = p(2, 3);
  const double ty = (p(1, 3) - (*k)(1, 2) * tz) / fy;
  *t = Eigen::Vector3d((p(0, 3) - (*k)(0, 2) * tz) / fx, ty, tz);
}

// Width and height from a PNG header (ReadImageHeader, image_file.h), or an
// InputError naming the file.
std::pair<int, int> PngSize(const fs::path& path) {
  const std::optional<ImageHeader> header = ReadImageHeader(path);
  if (!header || std::string(header->format) != "png")
    MCVO_THROW_INPUT(path.string(), ": not a PNG image (bad or truncated header)");
  if (header->width > 1'000'000 || header->height > 1'000'000)
    MCVO_THROW_INPUT(path.string(), ": PNG header gives an invalid size ", header->width, "x", header->height);
  return {static_cast<int>(header->width), static_cast<int>(header->height)};
}

// The NNNNNN.png images of a camera folder, by frame index, and their size
// (the first image's; every other must match).
struct CameraImages {
  std::map<int64_t, fs::path> images;
  int width = 0, height = 0;
};

CameraImages ListImages(const fs::path& folder) {
  CameraImages out;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    const std::string file = entry.path().filename().string();
    if (file.size() != 10 || entry.path().extension() != ".png" ||
        !std::all_of(file.begin(), file.begin() + 6, [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    out.images[*ParseInt64(file.substr(0, 6))] = entry.path();
  }
  if (ec) MCVO_THROW_INPUT(folder.string(), ": cannot list folder: ", ec.message());
  if (out.images.empty()) MCVO_THROW_INPUT(folder.string(), ": no NNNNNN.png image");
  const fs::path& first = out.images.begin()->second;
  std::tie(out.width, out.height) = PngSize(first);
  for (const auto& [index, path] : out.images) {
    const auto [width, height] = PngSize(path);
    if (width != out.width || height != out.height) {
      MCVO_THROW_INPUT(path.string(), ": image is ", width, "x", height, ", the first image of the folder (",
                       first.filename().string(), ") is ", out.width, "x", out.height);
    }
  }
  return out;
}

// The chosen camera numbers: options.cameras, or the grey pair, else the
// colour pair, else every camera folder there is.
std::vector<int> SelectCameras(const DatasetOptions& options, const fs::path& folder,
                               std::vector<std::string>* log) {
  std::vector<int> chosen;
  if (!options.cameras.empty()) {
    for (const std::string& name : options.cameras) {
      const int k = CameraIndex(name);
      if (k < 0) {
        throw UsageError(StrCat("cameras: '", name,
                                "' is not a KITTI odometry camera (image_00, image_01, image_02, image_03: "
                                "the folders image_0 .. image_3)"));
      }
      if (!IsDirectory(folder / FolderName(k)))
        MCVO_THROW_INPUT((folder / FolderName(k)).string(), ": missing image folder of camera ", name);
      chosen.push_back(k);
    }
    return chosen;
  }
  std::array<bool, kNumCameras> present{};
  for (int k = 0; k < kNumCameras; ++k) present[static_cast<size_t>(k)] = IsDirectory(folder / FolderName(k));
  if (present[0] && present[1]) {
    chosen = {0, 1};
  } else if (present[2] && present[3]) {
    chosen = {2, 3};
  } else {
    for (int k = 0; k < kNumCameras; ++k)
      if (present[static_cast<size_t>(k)]) chosen.push_back(k);
  }
  if (chosen.empty()) MCVO_THROW_INPUT(folder.string(), ": no camera folder (image_0 .. image_3)");
  std::string names;
  for (const int k : chosen) names += (names.empty() ? "" : ", ") + CameraName(k);
  log->push_back(StrCat("cameras: ", names,
                        " (default: the grey pair, else the colour pair, else what "
                        "there is; --cameras chooses)"));
  return chosen;
}

// times.txt: one time in seconds per frame, strictly increasing.
std::vector<int64_t> ReadTimes(const fs::path& path, int64_t frames, const fs::path& last_image) {
  if (!IsFile(path)) MCVO_THROW_INPUT(path.string(), ": missing frame times (", WhyNotAFile(path), ")");
  const std::string content = ReadFileToString(path);
  std::vector<int64_t> times;
  int number = 0, blank_line = 0;
  size_t start = 0;
  while (start < content.size()) {
    size_t end = content.find('\n', start);
    if (end == std::string::npos) end = content.size();
    const std::string_view text = Trim(std::string_view(content).substr(start, end - start));
    start = end + 1;
    ++number;
    if (text.empty()) {
      if (blank_line == 0) blank_line = number;
      continue;
    }
    if (blank_line != 0) MCVO_THROW_INPUT(path.string(), ":", blank_line, ": blank line between frame times");
    const std::optional<int64_t> t_ns = ParseSecondsToNs(text);
    if (!t_ns) MCVO_THROW_INPUT(path.string(), ":", number, ": expected a time in seconds, got '", text, "'");
    if (!times.empty() && *t_ns <= times.back()) {
      MCVO_THROW_INPUT(path.string(), ":", number, ": time ", FormatNsAsSeconds(*t_ns),
                       " s is not after the previous one (", FormatNsAsSeconds(times.back()), " s)");
    }
    times.push_back(*t_ns);
  }
  const int64_t count = static_cast<int64_t>(times.size());
  if (count < frames) {
    MCVO_THROW_INPUT(path.string(), ":", count + 1, ": no time for frame ", count, ": times.txt has ", count,
                     " line(s), the images go up to ", last_image.string(), " (", frames, " frames)");
  }
  if (count > frames) {
    MCVO_THROW_INPUT(path.string(), ":", frames + 1, ": ", count, " times for ", frames,
                     " frames (the last image is ", last_image.string(), "): one time per frame expected");
  }
  return times;
}

}  // namespace

DatasetIndex ReadKittiOdometryDataset(const DatasetOptions& options) {
  DatasetIndex index;
  index.format = "kitti";
  index.root = options.root;
  const SequencePaths sequence = ResolveSequence(options, &index.log);
  index.name = sequence.name;
  const fs::path calib_path = sequence.folder / "calib.txt";
  const Calibration calibration = ReadCalibration(calib_path, &index.log);
  const std::vector<int> chosen = SelectCameras(options, sequence.folder, &index.log);

  Eigen::Matrix3d k0;
  Eigen::Vector3d t0;
  SplitProjection(*calibration.p[0], StrCat(calib_path.string(), ": P0"), &k0, &t0);
  std::vector<CameraImages> cameras;
  for (const int k : chosen) {
    const std::string where = StrCat(calib_path.string(), ": P", k);
    if (!calibration.p[static_cast<size_t>(k)])
      MCVO_THROW_INPUT(calib_path.string(), ": missing P", k, " (camera ", CameraName(k), ")");
    Eigen::Matrix3d kk;
    Eigen::Vector3d t;
    SplitProjection(*calibration.p[static_cast<size_t>(k)], where, &kk, &t);
    cameras.push_back(ListImages(sequence.folder / FolderName(k)));
    Camera camera;
    camera.name = CameraName(k);
    camera.model = CameraModelId::kPinhole;
    camera.params = {kk(0, 0), kk(1, 1), kk(0, 2), kk(1, 2)};
    camera.width = cameras.back().width;
    camera.height = cameras.back().height;
    camera.cam_from_rig = Rigid3d(Eigen::Quaterniond::Identity(), t - t0);
    index.rig.cameras.push_back(camera);
  }
  index.log.push_back(
      StrCat("kitti: rig frame = camera 0 (P0); cam_from_rig of camera i = [I | K_i^-1 P_i[:,3]",
             t0.isZero() ? "" : " - K_0^-1 P0[:,3]", "]"));
  index.masks.assign(index.rig.cameras.size(), cv::Mat());

  // Frame count: up to the last image of any chosen camera.
  int64_t frames = 0;
  fs::path last_image;
  for (const CameraImages& camera : cameras) {
    if (camera.images.rbegin()->first + 1 > frames) {
      frames = camera.images.rbegin()->first + 1;
      last_image = camera.images.rbegin()->second;
    }
  }
  const std::vector<int64_t> times = ReadTimes(sequence.folder / "times.txt", frames, last_image);

  // Frames: the reference (first chosen) camera's images; the others' at the same index.
  const size_t num_cameras = cameras.size();
  std::vector<int> no_image(num_cameras, 0);
  int skipped = 0;
  for (const auto& [frame_index, reference_image] : cameras[0].images) {
    DatasetFrame frame;
    frame.t_ns = times[static_cast<size_t>(frame_index)];
    frame.images.push_back(reference_image);
    bool complete = true;
    for (size_t c = 1; c < num_cameras; ++c) {
      const auto it = cameras[c].images.find(frame_index);
      complete = complete && it != cameras[c].images.end();
      if (it == cameras[c].images.end()) ++no_image[c];
      frame.images.push_back(it == cameras[c].images.end() ? fs::path() : it->second);
    }
    if (!complete && options.missing_images == MissingImagePolicy::kSkipFrame) {
      ++skipped;
      continue;
    }
    index.frames.push_back(std::move(frame));
  }
  const char* action =
      options.missing_images == MissingImagePolicy::kSkipFrame ? "skipped" : "marked missing";
  int without_reference = 0;
  for (size_t c = 1; c < num_cameras; ++c) {
    if (no_image[c] > 0)
      index.log.push_back(
          StrCat(index.rig.cameras[c].name, ": no image at ", no_image[c], " frame(s), ", action));
    for (const auto& entry : cameras[c].images)
      without_reference += cameras[0].images.count(entry.first) == 0;
  }
  if (skipped > 0) index.log.push_back(StrCat("skipped ", skipped, " incomplete frame(s)"));
  if (without_reference > 0) {
    index.log.push_back(StrCat(without_reference, " image(s) of other cameras at frames without a ",
                               index.rig.cameras[0].name, " image (the reference camera) not used"));
  }
  index.log.push_back(StrCat(index.frames.size(), " frame(s), reference camera ", index.rig.cameras[0].name));

  // Ground truth: line i = world_from_cam0 at frame i = world_from_rig.
  if (IsFile(sequence.poses)) {
    Trajectory ground_truth = ReadTrajectory(sequence.poses, TrajectoryFormat::kKitti);
    if (ground_truth.poses.size() > times.size()) {
      MCVO_THROW_INPUT(sequence.poses.string(), ":", times.size() + 1, ": ", ground_truth.poses.size(),
                       " poses for ", times.size(), " frames (times.txt)");
    }
    for (StampedPose& pose : ground_truth.poses) pose.t_ns = times[static_cast<size_t>(pose.frame_index)];
    ground_truth.has_time = true;
    index.log.push_back(StrCat("ground truth: ", ground_truth.poses.size(), " pose(s) from ",
                               sequence.poses.lexically_normal().string(),
                               " (world_from_cam0 = world_from_rig)"));
    index.ground_truth = std::move(ground_truth);
  } else {
    index.log.push_back(
        StrCat("no ground truth (", sequence.poses.lexically_normal().string(), " does not exist)"));
  }
  for (const std::string& line : index.log) MCVO_LOG(kDebug, line);
  return index;
}

}  // namespace mcvo
