// `mcvo vocab`: the bag-of-words vocabulary of loop closure
// (docs/loop-closure.md, "Vocabulary").
//
//   mcvo vocab train --dataset DIR --out FILE [--descriptor orb|xfeat|superpoint] ...
//   mcvo vocab info FILE
//
// train: every S-th frame of one or more datasets, the descriptors of every
// camera image (ORB by default: the descriptors loop closure uses), then
// hierarchical k-means (loop/vocabulary.h), written atomically. Order of
// work: flags, datasets (metadata), detectors (a network model is loaded and
// checked here), the output folder, and only then images are decoded: bad
// input is reported at start-up. The file is identical at any --threads.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "command.h"
#include "dataset_args.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/frontend/detector.h"
#include "mcvo/frontend/opencv_threads.h"
#include "mcvo/loop/vocabulary.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/output_folder.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/progress.h"
#include "mcvo/util/sha256.h"
#include "mcvo/util/strings.h"

namespace mcvo::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Detections stay this far inside the image (pixels).
constexpr int kBorderPx = 8;

struct TrainArgs {
  DatasetArgs dataset;
  std::string extra_datasets;  // comma-separated
  std::string out;
  std::string descriptor = "orb";
  std::string model;
  int features = 500;
  int frame_step = 1;
  int max_frames = 0;
  int threads = 0;
  int seed = 0;
  VocabularyTrainOptions train;
};

struct Extraction {
  std::vector<cv::Mat> descriptors;  // one per camera image, in (dataset, frame, camera) order
  int frames = 0;
  int64_t rows = 0;
};

// Descriptors of one camera image. ORB is cv::ORB with its default
// parameters (Harris score) and `features` keypoints inside the mask, the
// extraction loop closure runs on keyframes (src/loop/loop_closer.cc), so the
// vocabulary sees the descriptors it will quantise; the networks are the
// frontend's detectors. Not thread-safe: one extractor per thread.
class Extractor {
 public:
  Extractor(const FrontendOptions& frontend, int features) : features_(features) {
    if (frontend.detector == DetectorType::kOrb) {
      orb_ = cv::ORB::create(features);
    } else {
      network_ = CreateDetector(frontend);  // loads and checks the model
      MCVO_CHECK(network_->DescriptorSize() > 0);
    }
  }

  cv::Mat Extract(const cv::Mat& image, const cv::Mat& mask) {
    const bool use_mask = !mask.empty() && mask.size() == image.size();
    if (orb_) {
      std::vector<cv::KeyPoint> keypoints;
      cv::Mat descriptors;
      orb_->detectAndCompute(image, use_mask ? mask : cv::noArray(), keypoints, descriptors);
      return descriptors;
    }
    return network_->Detect(image, use_mask ? mask : cv::Mat(), features_, kBorderPx).descriptors;
  }

 private:
  int features_;
  cv::Ptr<cv::ORB> orb_;
  std::unique_ptr<Detector> network_;
};

// The descriptors of every selected frame of one dataset, appended to *out.
// Cameras run in parallel, camera c on extractor c % extractors.size(), so an
// extractor is never used by two threads at once; results go to per-camera
// slots and are appended in camera order.
void ExtractDataset(const DatasetIndex& index, const TrainArgs& args, std::vector<Extractor>* extractors,
                    int threads, Extraction* out) {
  DatasetIndex selected = index;
  selected.frames.clear();
  for (size_t i = 0; i < index.frames.size(); i += static_cast<size_t>(args.frame_step)) {
    if (args.max_frames > 0 && static_cast<int>(selected.frames.size()) >= args.max_frames) break;
    selected.frames.push_back(index.frames[i]);
  }
  const int cameras = selected.rig.NumCameras();
  FrameStreamOptions stream_options;
  stream_options.threads = threads;
  FrameStream stream(selected, stream_options);
  ProgressBar progress("vocab " + index.name, static_cast<int64_t>(selected.frames.size()), "frames");
  const size_t workers = std::min(extractors->size(), static_cast<size_t>(cameras));
  int done = 0;
  while (std::optional<FrameImages> frame = stream.Next()) {
    std::vector<cv::Mat> per_camera(static_cast<size_t>(cameras));
    const auto work = [&](size_t worker) {
      for (size_t c = worker; c < static_cast<size_t>(cameras); c += workers) {
        const cv::Mat& image = frame->images[c];
        if (image.empty()) continue;  // missing image
        per_camera[c] =
            (*extractors)[worker].Extract(image, c < index.masks.size() ? index.masks[c] : cv::Mat());
      }
    };
    ParallelFor(static_cast<int>(workers), static_cast<int>(workers),
                [&](int w) { work(static_cast<size_t>(w)); });
    for (cv::Mat& d : per_camera) {
      if (d.empty()) continue;
      out->rows += d.rows;
      out->descriptors.push_back(std::move(d));
    }
    ++out->frames;
    progress.Update(++done);
  }
  progress.Finish();
}

int RunTrain(int argc, const char* const* argv) {
  const ScopedSerialOpenCv serial_opencv;  // mcvo's threads only (frontend/opencv_threads.h)
  TrainArgs a;
  ArgParser args("mcvo vocab train",
                 "Trains a bag-of-words vocabulary (hierarchical k-means) on the descriptors of a dataset's "
                 "images.");
  AddDatasetArgs(&args, &a.dataset, /*dataset_required=*/true);
  args.AddString(
      "extra-datasets", &a.extra_datasets, "DIR,DIR",
      "more datasets to train on, read with the same --format, --cameras, --frame-step, --max-frames");
  args.AddString("out", &a.out, "FILE", "vocabulary file to write", /*required=*/true);
  args.AddString("descriptor", &a.descriptor, "NAME", "orb | xfeat | superpoint");
  args.AddString("model", &a.model, "FILE", "ONNX model of xfeat / superpoint");
  args.AddInt("features", &a.features, "descriptors per camera image at most (the strongest detections)");
  args.AddInt("branching", &a.train.branching, "k of the k-means at every node");
  args.AddInt("levels", &a.train.levels, "depth of the tree: at most branching^levels words");
  args.AddInt("iterations", &a.train.max_iterations, "k-means iterations per node at most");
  args.AddInt("frame-step", &a.frame_step, "use every N-th frame");
  args.AddInt("max-frames", &a.max_frames,
              "use at most N frames of each dataset (after --frame-step); 0: all");
  args.AddInt("threads", &a.threads, "threads for decoding, extraction and training; 0: all cores");
  args.AddInt("seed", &a.seed, "seed of the k-means++ seeding");
  args.AddEpilog(
      "Each camera image is one training image (IDF counts images). The file is identical at any --threads.\n"
      "example: mcvo vocab train --dataset seq/kitti360 --frame-step 5 --out vocab.bin\n"
      "The default vocabulary config/vocabulary_orb.bin is made by tools/make_default_vocabulary.sh.\n");
  if (!args.Parse(argc, argv)) return kExitOk;
  if (a.features < 1) throw UsageError(StrCat("--features: must be >= 1, got ", a.features));
  if (a.frame_step < 1) throw UsageError(StrCat("--frame-step: must be >= 1, got ", a.frame_step));
  if (a.max_frames < 0) throw UsageError(StrCat("--max-frames: must be >= 0, got ", a.max_frames));
  if (a.threads < 0) throw UsageError(StrCat("--threads: must be >= 0, got ", a.threads));
  if (a.seed < 0) throw UsageError(StrCat("--seed: must be >= 0, got ", a.seed));
  a.train.seed = static_cast<uint64_t>(a.seed);
  a.train.threads = a.threads;
  try {
    a.train.Check();
  } catch (const UsageError& e) {
    // The field names are the flags' (max_iterations: --iterations).
    const std::string message = e.what();
    const std::string field = "max_iterations";
    throw UsageError("--" +
                     (message.rfind(field, 0) == 0 ? "iterations" + message.substr(field.size()) : message));
  }
  FrontendOptions frontend;
  if (a.descriptor == "orb") {
    frontend.detector = DetectorType::kOrb;
    if (!a.model.empty()) throw UsageError("--model: only for --descriptor xfeat or superpoint");
  } else if (a.descriptor == "xfeat" || a.descriptor == "superpoint") {
    frontend.detector = a.descriptor == "xfeat" ? DetectorType::kXFeat : DetectorType::kSuperPoint;
    if (a.model.empty()) throw UsageError(StrCat("--descriptor ", a.descriptor, " needs --model FILE"));
    frontend.model_path = a.model;
  } else {
    throw UsageError(
        StrCat("--descriptor: unknown value '", a.descriptor, "' (known: orb, xfeat, superpoint)"));
  }
  const int threads = ResolveThreads(a.threads);
  const Clock::time_point start = Clock::now();

  // Datasets: metadata of all of them first.
  std::vector<std::string> roots = {a.dataset.root};
  for (const std::string_view field : SplitFields(a.extra_datasets, ',')) {
    if (!field.empty()) roots.emplace_back(field);
  }
  std::vector<DatasetIndex> indices;
  int max_cameras = 0;
  for (const std::string& root : roots) {
    DatasetArgs dataset = a.dataset;
    dataset.root = root;
    indices.push_back(OpenDataset(MakeDatasetOptions(dataset)));
    max_cameras = std::max(max_cameras, indices.back().rig.NumCameras());
  }
  // Extractors (a network model is loaded and checked now), one per thread over cameras.
  std::vector<Extractor> extractors;
  for (int i = 0; i < std::max(1, std::min(threads, max_cameras)); ++i)
    extractors.emplace_back(frontend, a.features);
  // Never written over or inside an input (util/output_folder.h).
  std::vector<fs::path> inputs(roots.begin(), roots.end());
  inputs.emplace_back(a.model);
  for (const DatasetIndex& index : indices) inputs.push_back(index.root);
  CheckOutputFile(a.out, inputs, "--out");
  // The output folder must exist (the file itself is written at the end).
  const fs::path out_dir = fs::path(a.out).parent_path();
  if (!out_dir.empty() && !fs::is_directory(out_dir)) {
    MCVO_THROW_INPUT(a.out, ": folder ", out_dir.string(), " does not exist");
  }

  Extraction extraction;
  for (const DatasetIndex& index : indices) {
    MCVO_LOG(kInfo, "vocab train: ", index.name, " (", index.format, "), ", index.rig.NumCameras(),
             " cameras, ", index.frames.size(), " frames, every ", a.frame_step, ", ", a.descriptor,
             " descriptors, at most ", a.features, " per image");
    ExtractDataset(index, a, &extractors, threads, &extraction);
  }
  const double extract_seconds = SecondsSince(start);
  if (extraction.rows == 0) {
    MCVO_THROW_INPUT(a.dataset.root, ": no ", a.descriptor, " descriptors in ", extraction.frames,
                     " frames: nothing to train on");
  }
  const Clock::time_point train_start = Clock::now();
  const Vocabulary vocabulary = TrainVocabulary(extraction.descriptors, a.train);
  const double train_seconds = SecondsSince(train_start);
  vocabulary.Save(a.out);
  std::cout << "vocab train: " << extraction.descriptors.size() << " images (" << extraction.frames
            << " frames of " << indices.size() << (indices.size() == 1 ? " dataset" : " datasets") << "), "
            << extraction.rows << " " << a.descriptor << " descriptors, " << vocabulary.num_words()
            << " words (branching " << vocabulary.branching() << ", levels " << vocabulary.levels() << "), "
            << FormatFixed(SecondsSince(start), 1) << " s (extraction " << FormatFixed(extract_seconds, 1)
            << " s, training " << FormatFixed(train_seconds, 1) << " s); wrote " << a.out << " ("
            << fs::file_size(a.out) << " bytes)\n";
  return kExitOk;
}

int RunInfo(int argc, const char* const* argv) {
  std::string file;
  ArgParser args("mcvo vocab info FILE", "Describes a vocabulary file.");
  std::vector<const char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (file.empty() && std::string(argv[i]).rfind('-', 0) != 0) {
      file = argv[i];
    } else {
      rest.push_back(argv[i]);
    }
  }
  if (!args.Parse(static_cast<int>(rest.size()), rest.data())) return kExitOk;
  if (file.empty()) throw UsageError("expected the vocabulary FILE (mcvo vocab info FILE)");
  const Vocabulary vocabulary = Vocabulary::Load(file);
  const bool binary = vocabulary.kind() == DescriptorKind::kBinary;
  std::vector<double> idf;
  idf.reserve(static_cast<size_t>(vocabulary.num_words()));
  for (int w = 0; w < vocabulary.num_words(); ++w) idf.push_back(vocabulary.Idf(static_cast<uint32_t>(w)));
  std::sort(idf.begin(), idf.end());
  const size_t zero = static_cast<size_t>(std::count(idf.begin(), idf.end(), 0.0));
  std::cout << "file: " << file << " (" << fs::file_size(file) << " bytes, sha256 " << Sha256File(file)
            << ")\n"
            << "kind: " << (binary ? "binary" : "float") << ", " << vocabulary.descriptor_size()
            << (binary ? "-byte descriptors (Hamming)" : "-float descriptors (L2)") << "\n"
            << "branching: " << vocabulary.branching() << ", levels: " << vocabulary.levels() << "\n"
            << "nodes: " << vocabulary.num_nodes() << ", words: " << vocabulary.num_words() << " (at most "
            << FormatDouble(std::pow(static_cast<double>(vocabulary.branching()), vocabulary.levels()))
            << ")\n"
            << "idf: min " << FormatFixed(idf.front(), 3) << ", median "
            << FormatFixed(idf[idf.size() / 2], 3) << ", max " << FormatFixed(idf.back(), 3) << "; " << zero
            << " words of idf 0 (left out of bags of words)\n";
  return kExitOk;
}

const char kUsage[] =
    "usage: mcvo vocab <train|info> [options]\n\n"
    "The bag-of-words vocabulary of loop closure (docs/loop-closure.md).\n\n"
    "  train   trains a vocabulary on a dataset's images (mcvo vocab train --help)\n"
    "  info    describes a vocabulary file: mcvo vocab info FILE\n";

int RunVocab(int argc, const char* const* argv) {
  if (argc < 1) throw UsageError("expected a subcommand: train or info (see mcvo vocab --help)");
  const std::string sub = argv[0];
  if (sub == "--help" || sub == "-h" || sub == "help") {
    std::cout << kUsage;
    return kExitOk;
  }
  if (sub == "train") return RunTrain(argc - 1, argv + 1);
  if (sub == "info") return RunInfo(argc - 1, argv + 1);
  throw UsageError(StrCat("unknown subcommand '", sub, "' (known: train, info)"));
}

const CommandRegistrar kRegistrar("vocab",
                                  {"train or describe a bag-of-words vocabulary (loop closure)", RunVocab});

}  // namespace
}  // namespace mcvo::tools
