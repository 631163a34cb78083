// The bag-of-words vocabulary: training recovers synthetic clusters (binary
// and float), bags of words and the L1 score, ORB on textured images, the
// file format (round trip, every kind of damage), thread independence, the
// `mcvo vocab` command and the default vocabulary in config/.
#include "mcvo/loop/vocabulary.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/hash.h"
#include "mcvo/util/sha256.h"
#include "tools/run_mcvo.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

// One folder per process: ctest runs every TEST as its own process, in parallel.
const fs::path& Root() {
  static const fs::path root = [] {
    const fs::path dir =
        fs::path(::testing::TempDir()) / ("mcvo_vocabulary_test_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
  }();
  return root;
}

// Synthetic clustered descriptors: cluster c's descriptors are its centre
// with a little noise. Image i holds `per_image` descriptors of each cluster
// in its own subset (cluster c is in image i when (i + c) % 3 != 0), so
// words have different IDFs.
struct Clustered {
  std::vector<cv::Mat> images;
  std::vector<std::vector<int>> cluster_of_row;  // per image
};

cv::Mat BinaryCentres(int clusters, int bytes, uint64_t seed) {
  SplitMix64Rng rng(seed);
  cv::Mat centres(clusters, bytes, CV_8UC1);
  for (int c = 0; c < clusters; ++c) {
    for (int b = 0; b < bytes; ++b) centres.at<uint8_t>(c, b) = static_cast<uint8_t>(rng.Next() >> 56);
  }
  return centres;
}

// Binary: `flips` random bits of the centre flipped.
Clustered MakeBinaryClusters(const cv::Mat& centres, int images, int per_image, int flips, uint64_t seed) {
  SplitMix64Rng rng(seed);
  Clustered out;
  const int bits = 8 * centres.cols;
  for (int i = 0; i < images; ++i) {
    cv::Mat rows(0, centres.cols, CV_8UC1);
    std::vector<int> clusters;
    for (int c = 0; c < centres.rows; ++c) {
      if ((i + c) % 3 == 0) continue;
      for (int k = 0; k < per_image; ++k) {
        cv::Mat row = centres.row(c).clone();
        for (int f = 0; f < flips; ++f) {
          const int bit = rng.UniformInt(0, bits - 1);
          row.at<uint8_t>(0, bit / 8) ^= static_cast<uint8_t>(1u << (bit % 8));
        }
        rows.push_back(row);
        clusters.push_back(c);
      }
    }
    out.images.push_back(rows);
    out.cluster_of_row.push_back(clusters);
  }
  return out;
}

double Gaussian(SplitMix64Rng* rng) {
  const double u = OpenUnitFromHash(rng->Next());
  const double v = UnitFromHash(rng->Next());
  return std::sqrt(-2.0 * std::log(u)) * std::cos(6.283185307179586 * v);
}

// Float: centre + N(0, sigma^2) per dimension.
Clustered MakeFloatClusters(const cv::Mat& centres, int images, int per_image, double sigma, uint64_t seed) {
  SplitMix64Rng rng(seed);
  Clustered out;
  for (int i = 0; i < images; ++i) {
    cv::Mat rows(0, centres.cols, CV_32FC1);
    std::vector<int> clusters;
    for (int c = 0; c < centres.rows; ++c) {
      if ((i + c) % 3 == 0) continue;
      for (int k = 0; k < per_image; ++k) {
        cv::Mat row = centres.row(c).clone();
        for (int d = 0; d < centres.cols; ++d)
          row.at<float>(0, d) += static_cast<float>(sigma * Gaussian(&rng));
        rows.push_back(row);
        clusters.push_back(c);
      }
    }
    out.images.push_back(rows);
    out.cluster_of_row.push_back(clusters);
  }
  return out;
}

// Word of every row of every image, per cluster.
std::map<int, std::set<uint32_t>> WordsPerCluster(const Vocabulary& vocabulary, const Clustered& data) {
  std::map<int, std::set<uint32_t>> words;
  for (size_t i = 0; i < data.images.size(); ++i) {
    for (int r = 0; r < data.images[i].rows; ++r) {
      words[data.cluster_of_row[i][static_cast<size_t>(r)]].insert(vocabulary.WordOf(data.images[i].row(r)));
    }
  }
  return words;
}

void ExpectOneWordPerCluster(const Vocabulary& vocabulary, const Clustered& data, int clusters) {
  const std::map<int, std::set<uint32_t>> words = WordsPerCluster(vocabulary, data);
  ASSERT_EQ(static_cast<int>(words.size()), clusters);
  std::set<uint32_t> all;
  for (const auto& [cluster, set] : words) {
    EXPECT_EQ(set.size(), 1u) << "cluster " << cluster << " spread over " << set.size() << " words";
    all.insert(set.begin(), set.end());
  }
  EXPECT_EQ(static_cast<int>(all.size()), clusters) << "two clusters share a word";
}

TEST(Vocabulary, BinaryTrainingRecoversClusters) {
  constexpr int kClusters = 8;
  const cv::Mat centres = BinaryCentres(kClusters, 32, 11);
  const Clustered train = MakeBinaryClusters(centres, 30, 10, 3, 12);
  VocabularyTrainOptions options;
  options.branching = kClusters;
  options.levels = 1;
  options.seed = 5;
  const Vocabulary vocabulary = TrainVocabulary(train.images, options);
  EXPECT_EQ(vocabulary.kind(), DescriptorKind::kBinary);
  EXPECT_EQ(vocabulary.descriptor_size(), 32);
  EXPECT_EQ(vocabulary.num_words(), kClusters);
  EXPECT_EQ(vocabulary.num_nodes(), kClusters + 1);
  ExpectOneWordPerCluster(vocabulary, train, kClusters);
  // New descriptors of the same clusters land in the same words.
  const Clustered test = MakeBinaryClusters(centres, 6, 5, 3, 99);
  const auto train_words = WordsPerCluster(vocabulary, train);
  const auto test_words = WordsPerCluster(vocabulary, test);
  EXPECT_EQ(train_words, test_words);
  // Each cluster is in 2/3 of the images: IDF log(3/2) (30 images, 20 each).
  for (int w = 0; w < vocabulary.num_words(); ++w) {
    EXPECT_NEAR(vocabulary.Idf(static_cast<uint32_t>(w)), std::log(30.0 / 20.0), 1e-12);
  }
}

TEST(Vocabulary, BinaryClustersNeedingTwoLevels) {
  // 12 clusters, branching 4: one level cannot separate them, two can; a
  // third level finds nothing more to split (the majority centre of noisy
  // copies of one descriptor is that descriptor, so k-majority does not cut
  // a cluster in parts: such a node stays a leaf).
  constexpr int kClusters = 12;
  const cv::Mat centres = BinaryCentres(kClusters, 32, 21);
  const Clustered train = MakeBinaryClusters(centres, 30, 12, 6, 22);
  VocabularyTrainOptions options;
  options.branching = 4;
  options.levels = 3;
  const Vocabulary vocabulary = TrainVocabulary(train.images, options);
  EXPECT_EQ(vocabulary.num_words(), kClusters);
  EXPECT_GT(vocabulary.num_nodes(), 1 + 4 + kClusters - 1);  // the root, level 1, the words below
  ExpectOneWordPerCluster(vocabulary, train, kClusters);
  std::map<uint32_t, std::set<int>> clusters_of_word;
  for (size_t i = 0; i < train.images.size(); ++i) {
    for (int r = 0; r < train.images[i].rows; ++r) {
      clusters_of_word[vocabulary.WordOf(train.images[i].row(r))].insert(
          train.cluster_of_row[i][static_cast<size_t>(r)]);
    }
  }
  EXPECT_EQ(static_cast<int>(clusters_of_word.size()), vocabulary.num_words())
      << "every leaf holds descriptors";
  for (const auto& [word, clusters] : clusters_of_word) EXPECT_EQ(clusters.size(), 1u) << "word " << word;
}

TEST(Vocabulary, FloatTrainingRecoversHierarchicalClusters) {
  // 4 groups of 4 clusters: level 1 separates the groups, level 2 the
  // clusters of a group.
  constexpr int kDims = 32;
  SplitMix64Rng rng(31);
  cv::Mat centres(16, kDims, CV_32FC1);
  for (int g = 0; g < 4; ++g) {
    std::vector<double> group(kDims);
    for (double& v : group) v = Gaussian(&rng);
    for (int s = 0; s < 4; ++s) {
      for (int d = 0; d < kDims; ++d) {
        centres.at<float>(4 * g + s, d) =
            static_cast<float>(group[static_cast<size_t>(d)] + 0.03 * Gaussian(&rng));
      }
    }
  }
  const Clustered train = MakeFloatClusters(centres, 24, 8, 0.0015, 32);
  VocabularyTrainOptions options;
  options.branching = 4;
  options.levels = 2;
  options.seed = 3;
  const Vocabulary vocabulary = TrainVocabulary(train.images, options);
  EXPECT_EQ(vocabulary.kind(), DescriptorKind::kFloat);
  EXPECT_EQ(vocabulary.descriptor_size(), kDims);
  EXPECT_EQ(vocabulary.num_words(), 16);
  ExpectOneWordPerCluster(vocabulary, train, 16);
  // The clusters of one group share the level-1 node: words 4g..4g+3 in
  // breadth-first leaf order.
  const auto words = WordsPerCluster(vocabulary, train);
  for (int g = 0; g < 4; ++g) {
    std::set<uint32_t> parents;
    for (int s = 0; s < 4; ++s) parents.insert(*words.at(4 * g + s).begin() / 4);
    EXPECT_EQ(parents.size(), 1u) << "group " << g;
  }
}

TEST(Vocabulary, TransformIsL1NormalisedTfIdf) {
  const cv::Mat centres = BinaryCentres(6, 32, 41);
  const Clustered train = MakeBinaryClusters(centres, 12, 5, 2, 42);
  VocabularyTrainOptions options;
  options.branching = 6;
  options.levels = 1;
  const Vocabulary vocabulary = TrainVocabulary(train.images, options);
  ASSERT_EQ(vocabulary.num_words(), 6);
  // An image with 3 descriptors of cluster 0, 1 of cluster 1: TF 3/4, 1/4, equal IDFs.
  cv::Mat query;
  query.push_back(train.images[1].row(0));
  query.push_back(train.images[1].row(1));
  query.push_back(train.images[1].row(2));
  const int other = train.cluster_of_row[1][5];
  query.push_back(train.images[1].row(5));
  const BowVector bow = vocabulary.Transform(query);
  ASSERT_EQ(bow.size(), 2u);
  double sum = 0.0;
  for (const auto& [word, weight] : bow) {
    EXPECT_GT(weight, 0.0);
    sum += weight;
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
  EXPECT_NEAR(bow.at(vocabulary.WordOf(query.row(0))), 0.75, 1e-12);
  EXPECT_NEAR(bow.at(vocabulary.WordOf(query.row(3))), 0.25, 1e-12);
  EXPECT_NE(train.cluster_of_row[1][0], other);
  for (const cv::Mat& image : train.images) {
    const BowVector b = vocabulary.Transform(image);
    double s = 0.0;
    for (const auto& [word, weight] : b) s += weight;
    EXPECT_NEAR(s, 1.0, 1e-12);
  }
  EXPECT_TRUE(vocabulary.Transform(cv::Mat()).empty());
  // Wrong type or width: InputError.
  EXPECT_THROW(vocabulary.Transform(cv::Mat(3, 32, CV_32FC1, cv::Scalar(0))), InputError);
  EXPECT_THROW(vocabulary.Transform(cv::Mat(3, 16, CV_8UC1, cv::Scalar(0))), InputError);
}

TEST(Vocabulary, WordsInEveryImageHaveIdfZeroAndAreLeftOut) {
  // Two clusters in every image: IDF 0, and bags of their words are empty.
  const cv::Mat centres = BinaryCentres(2, 32, 51);
  std::vector<cv::Mat> images(5);
  for (cv::Mat& image : images) {
    image.push_back(centres.row(0));
    image.push_back(centres.row(1));
  }
  VocabularyTrainOptions options;
  options.branching = 2;
  options.levels = 2;
  const Vocabulary vocabulary = TrainVocabulary(images, options);
  EXPECT_EQ(vocabulary.num_words(), 2);  // identical descriptors are not split further
  EXPECT_EQ(vocabulary.Idf(0), 0.0);
  EXPECT_EQ(vocabulary.Idf(1), 0.0);
  EXPECT_TRUE(vocabulary.Transform(images[0]).empty());
}

TEST(BowScore, IdentityDisjointSymmetryAndTheL1Formula) {
  const BowVector a = {{1, 0.5}, {4, 0.3}, {9, 0.2}};
  const BowVector b = {{2, 0.6}, {7, 0.4}};
  const BowVector c = {{1, 0.1}, {4, 0.6}, {8, 0.3}};
  EXPECT_EQ(BowScore(a, a), 1.0);
  EXPECT_EQ(BowScore(c, c), 1.0);
  EXPECT_EQ(BowScore(a, b), 0.0);
  EXPECT_EQ(BowScore(a, BowVector()), 0.0);
  EXPECT_EQ(BowScore(BowVector(), BowVector()), 0.0);
  EXPECT_EQ(BowScore(a, c), BowScore(c, a));
  // DBoW2: 1 - 0.5 |a - c|_1 = 1 - 0.5 (0.4 + 0.3 + 0.2 + 0.3) = 0.4.
  EXPECT_NEAR(BowScore(a, c), 0.4, 1e-12);
  // Random L1-normalised vectors against the formula.
  SplitMix64Rng rng(61);
  for (int trial = 0; trial < 50; ++trial) {
    BowVector x, y;
    for (uint32_t w = 0; w < 40; ++w) {
      if (rng.Bernoulli(0.4)) x[w] = rng.Uniform(0.01, 1.0);
      if (rng.Bernoulli(0.4)) y[w] = rng.Uniform(0.01, 1.0);
    }
    if (x.empty() || y.empty()) continue;
    for (BowVector* v : {&x, &y}) {
      double sum = 0.0;
      for (const auto& [w, weight] : *v) sum += weight;
      for (auto& [w, weight] : *v) weight /= sum;
    }
    double l1 = 0.0;
    for (uint32_t w = 0; w < 40; ++w) {
      const double xw = x.count(w) ? x.at(w) : 0.0;
      const double yw = y.count(w) ? y.at(w) : 0.0;
      l1 += std::abs(xw - yw);
    }
    EXPECT_NEAR(BowScore(x, y), 1.0 - 0.5 * l1, 1e-12);
    EXPECT_EQ(BowScore(x, y), BowScore(y, x));
    EXPECT_GE(BowScore(x, y), 0.0);
    EXPECT_LE(BowScore(x, y), 1.0);
  }
}

// A textured image drawn with OpenCV: random rectangles, ellipses, lines and
// text in random grey levels on a smooth background.
cv::Mat TextureImage(uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat image(360, 480, CV_8UC1);
  cv::Mat noise(9, 12, CV_8UC1);
  rng.fill(noise, cv::RNG::UNIFORM, 60, 200);
  cv::resize(noise, image, image.size(), 0, 0, cv::INTER_CUBIC);
  for (int i = 0; i < 80; ++i) {
    const cv::Point p(rng.uniform(0, image.cols), rng.uniform(0, image.rows));
    const cv::Scalar grey(rng.uniform(0, 256));
    switch (rng.uniform(0, 4)) {
      case 0:
        cv::rectangle(image, p, p + cv::Point(rng.uniform(5, 60), rng.uniform(5, 60)), grey, cv::FILLED);
        break;
      case 1:
        cv::ellipse(image, p, cv::Size(rng.uniform(4, 40), rng.uniform(4, 40)), rng.uniform(0, 180), 0, 360,
                    grey, cv::FILLED);
        break;
      case 2:
        cv::line(image, p, cv::Point(rng.uniform(0, image.cols), rng.uniform(0, image.rows)), grey,
                 rng.uniform(1, 4));
        break;
      default:
        cv::putText(image, std::to_string(rng.uniform(0, 1000)), p, cv::FONT_HERSHEY_SIMPLEX,
                    rng.uniform(0.5, 1.5), grey, 2);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

cv::Mat OrbDescriptors(const cv::Mat& image) {
  cv::Ptr<cv::ORB> orb = cv::ORB::create(500);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  orb->detectAndCompute(image, cv::noArray(), keypoints, descriptors);
  return descriptors;
}

TEST(Vocabulary, OrbImageScoresHigherWithItsNoisyCopyThanWithAnotherImage) {
  std::vector<cv::Mat> train;
  for (uint64_t seed = 100; seed < 112; ++seed) train.push_back(OrbDescriptors(TextureImage(seed)));
  for (const cv::Mat& d : train) ASSERT_GT(d.rows, 200);
  VocabularyTrainOptions options;
  options.branching = 8;
  options.levels = 3;
  const Vocabulary vocabulary = TrainVocabulary(train, options);
  EXPECT_GT(vocabulary.num_words(), 300);

  // Images not seen in training, each against a noisy, slightly rotated and
  // scaled copy of itself and against the other images.
  constexpr int kQueries = 5;
  std::vector<BowVector> originals, copies;
  for (int q = 0; q < kQueries; ++q) {
    const cv::Mat image = TextureImage(500 + static_cast<uint64_t>(q));
    cv::Mat copy;
    const cv::Mat warp = cv::getRotationMatrix2D(cv::Point2f(240.f, 180.f), 4.0, 1.05);
    cv::warpAffine(image, copy, warp, image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    cv::Mat noise(copy.size(), CV_16SC1);
    cv::RNG(7 + static_cast<uint64_t>(q)).fill(noise, cv::RNG::NORMAL, 0, 6);
    cv::Mat noisy;
    copy.convertTo(noisy, CV_16SC1);
    noisy += noise;
    noisy.convertTo(copy, CV_8UC1);
    originals.push_back(vocabulary.Transform(OrbDescriptors(image)));
    copies.push_back(vocabulary.Transform(OrbDescriptors(copy)));
  }
  for (int q = 0; q < kQueries; ++q) {
    const double same = BowScore(originals[static_cast<size_t>(q)], copies[static_cast<size_t>(q)]);
    double best_other = 0.0;
    for (int r = 0; r < kQueries; ++r) {
      if (r == q) continue;
      best_other = std::max({best_other,
                             BowScore(originals[static_cast<size_t>(q)], originals[static_cast<size_t>(r)]),
                             BowScore(originals[static_cast<size_t>(q)], copies[static_cast<size_t>(r)])});
    }
    std::cout << "image " << q << ": score with its noisy copy " << same << ", best with another image "
              << best_other << "\n";
    EXPECT_GT(same, best_other + 0.05) << "image " << q;
  }
}

std::vector<cv::Mat> LargeBinarySet() {
  const cv::Mat centres = BinaryCentres(40, 32, 71);
  return MakeBinaryClusters(centres, 40, 8, 20, 72).images;  // 40 x 27 x 8 = 8,640 rows
}

std::vector<cv::Mat> LargeFloatSet() {
  SplitMix64Rng rng(81);
  cv::Mat centres(30, 24, CV_32FC1);
  for (int r = 0; r < centres.rows; ++r) {
    for (int d = 0; d < centres.cols; ++d) centres.at<float>(r, d) = static_cast<float>(Gaussian(&rng));
  }
  return MakeFloatClusters(centres, 40, 8, 0.3, 82).images;
}

TEST(Vocabulary, SaveLoadRoundTripGivesTheSameWords) {
  for (const bool binary : {true, false}) {
    const std::vector<cv::Mat> data = binary ? LargeBinarySet() : LargeFloatSet();
    VocabularyTrainOptions options;
    options.branching = 5;
    options.levels = 3;
    const Vocabulary vocabulary = TrainVocabulary(data, options);
    const fs::path path = Root() / (binary ? "round_trip_binary.bin" : "round_trip_float.bin");
    vocabulary.Save(path);
    const Vocabulary loaded = Vocabulary::Load(path);
    EXPECT_EQ(loaded.kind(), vocabulary.kind());
    EXPECT_EQ(loaded.descriptor_size(), vocabulary.descriptor_size());
    EXPECT_EQ(loaded.branching(), 5);
    EXPECT_EQ(loaded.levels(), 3);
    EXPECT_EQ(loaded.num_nodes(), vocabulary.num_nodes());
    ASSERT_EQ(loaded.num_words(), vocabulary.num_words());
    EXPECT_GT(loaded.num_words(), 30);
    for (int w = 0; w < loaded.num_words(); ++w) {
      EXPECT_EQ(loaded.Idf(static_cast<uint32_t>(w)), vocabulary.Idf(static_cast<uint32_t>(w)));
    }
    int rows = 0;
    for (const cv::Mat& image : data) {
      for (int r = 0; r < image.rows; ++r, ++rows)
        ASSERT_EQ(loaded.WordOf(image.row(r)), vocabulary.WordOf(image.row(r)));
      EXPECT_EQ(loaded.Transform(image), vocabulary.Transform(image));
    }
    EXPECT_GT(rows, 6000);
    // Saving the loaded vocabulary gives the same bytes.
    const fs::path again = Root() / "again.bin";
    loaded.Save(again);
    EXPECT_EQ(ReadFileToString(again), ReadFileToString(path));
    // No temporary file left behind.
    for (const auto& entry : fs::directory_iterator(Root())) {
      EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
    }
  }
}

// Load must throw InputError whose message names the file.
void ExpectLoadError(const fs::path& path, const std::string& expected_text) {
  try {
    Vocabulary::Load(path);
    ADD_FAILURE() << path << ": loaded without error";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(path.string()), std::string::npos) << message;
    EXPECT_NE(message.find(expected_text), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

void WriteBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

// Replaces the trailing SHA-256 so that the damage is found by the structural checks.
std::string WithChecksum(std::string bytes) {
  const std::string body = bytes.substr(0, bytes.size() - 32);
  const std::string hex = Sha256Hex(body);
  std::string raw;
  for (size_t i = 0; i < 32; ++i)
    raw.push_back(static_cast<char>(std::stoi(hex.substr(2 * i, 2), nullptr, 16)));
  return body + raw;
}

void PutU32(std::string* bytes, size_t offset, uint32_t value) {
  for (int i = 0; i < 4; ++i)
    (*bytes)[offset + static_cast<size_t>(i)] = static_cast<char>((value >> (8 * i)) & 0xFF);
}

TEST(Vocabulary, CorruptTruncatedAndForeignFilesThrowInputErrorNamingTheFile) {
  VocabularyTrainOptions options;
  options.branching = 4;
  options.levels = 2;
  const Vocabulary vocabulary = TrainVocabulary(LargeBinarySet(), options);
  const fs::path good = Root() / "good.bin";
  vocabulary.Save(good);
  const std::string bytes = ReadFileToString(good);
  ASSERT_GT(bytes.size(), 100u);
  const fs::path bad = Root() / "bad.bin";

  ExpectLoadError(Root() / "missing.bin", "cannot open");
  WriteBytes(bad, "");
  ExpectLoadError(bad, "not an mcvo vocabulary");
  WriteBytes(bad, "hello, this is not a vocabulary at all");
  ExpectLoadError(bad, "not an mcvo vocabulary");
  std::string wrong_magic = bytes;
  wrong_magic[7] = '2';
  WriteBytes(bad, wrong_magic);
  ExpectLoadError(bad, "not an mcvo vocabulary");
  std::string version = bytes;
  PutU32(&version, 8, 2);
  WriteBytes(bad, version);
  ExpectLoadError(bad, "unsupported vocabulary format version 2");

  // Every truncation, from the header on.
  for (size_t size = 8; size < bytes.size(); size += (size < 64 ? 1 : 97)) {
    WriteBytes(bad, bytes.substr(0, size));
    ExpectLoadError(bad, "truncated");
  }
  WriteBytes(bad, bytes.substr(0, bytes.size() - 1));
  ExpectLoadError(bad, "truncated");
  WriteBytes(bad, bytes + "x");
  ExpectLoadError(bad, "unexpected bytes after the end");

  // One flipped bit anywhere after the header: a bad checksum (or a
  // header value that no longer fits the size).
  for (size_t offset = 36; offset < bytes.size(); offset += 53) {
    std::string flipped = bytes;
    flipped[offset] = static_cast<char>(flipped[offset] ^ 0x10);
    WriteBytes(bad, flipped);
    ExpectLoadError(bad, "checksum mismatch");
  }
  // Header values out of range.
  for (const auto& [offset, value, text] :
       std::vector<std::tuple<size_t, uint32_t, std::string>>{{12, 7, "unknown descriptor kind 7"},
                                                              {16, 0, "descriptor size 0"},
                                                              {20, 1, "branching 1"},
                                                              {24, 0, "levels 0"},
                                                              {28, 0, "node count 0"},
                                                              {28, 0xFFFFFFFFu, "node count"},
                                                              {32, 0, "word count 0"},
                                                              {28, 1000000, "truncated"}}) {
    std::string header = bytes;
    PutU32(&header, offset, value);
    WriteBytes(bad, header);
    ExpectLoadError(bad, text);
  }
  // Damage behind a valid checksum: the structural checks.
  std::string tree = bytes;
  PutU32(&tree, 36, 3);  // the root has 4 children; with 3 the counts no longer tile the nodes
  WriteBytes(bad, WithChecksum(tree));
  ExpectLoadError(bad, "node");
  std::string wide = bytes;
  PutU32(&wide, 36, 5);  // more children than the branching
  WriteBytes(bad, WithChecksum(wide));
  ExpectLoadError(bad, "more than the branching 4");
  std::string idf = bytes;
  const size_t idf_offset = bytes.size() - 32 - 8 * static_cast<size_t>(vocabulary.num_words());
  const double minus = -1.0;
  std::memcpy(&idf[idf_offset], &minus, 8);
  WriteBytes(bad, WithChecksum(idf));
  ExpectLoadError(bad, "IDF of word 0");
  // The good file still loads.
  EXPECT_EQ(Vocabulary::Load(good).num_words(), vocabulary.num_words());
}

TEST(Vocabulary, TrainingIsIdenticalAtOneAndTwoThreads) {
  for (const bool binary : {true, false}) {
    const std::vector<cv::Mat> data = binary ? LargeBinarySet() : LargeFloatSet();
    std::string files[2];
    for (int threads = 1; threads <= 2; ++threads) {
      VocabularyTrainOptions options;
      options.branching = 6;
      options.levels = 3;
      options.seed = 9;
      options.threads = threads;
      const fs::path path = Root() / ("threads_" + std::to_string(threads) + ".bin");
      TrainVocabulary(data, options).Save(path);
      files[threads - 1] = ReadFileToString(path);
    }
    EXPECT_EQ(files[0], files[1]) << (binary ? "binary" : "float");
    // A different seed gives a different tree (the seed is used).
    VocabularyTrainOptions options;
    options.branching = 6;
    options.levels = 3;
    options.seed = 10;
    const fs::path path = Root() / "seed_10.bin";
    TrainVocabulary(data, options).Save(path);
    EXPECT_NE(ReadFileToString(path), files[0]);
  }
}

TEST(Vocabulary, BadTrainingInputIsRejected) {
  VocabularyTrainOptions options;
  EXPECT_THROW(TrainVocabulary({}, options), InputError);
  EXPECT_THROW(TrainVocabulary({cv::Mat(), cv::Mat()}, options), InputError);
  EXPECT_THROW(TrainVocabulary(
                   {cv::Mat(4, 32, CV_8UC1, cv::Scalar(1)), cv::Mat(4, 16, CV_8UC1, cv::Scalar(1))}, options),
               InputError);
  EXPECT_THROW(
      TrainVocabulary({cv::Mat(4, 32, CV_8UC1, cv::Scalar(1)), cv::Mat(4, 32, CV_32FC1, cv::Scalar(1))},
                      options),
      InputError);
  EXPECT_THROW(TrainVocabulary({cv::Mat(4, 8, CV_64FC1, cv::Scalar(1))}, options), InputError);
  cv::Mat nan(4, 8, CV_32FC1, cv::Scalar(0));
  nan.at<float>(2, 3) = std::nanf("");
  EXPECT_THROW(TrainVocabulary({nan}, options), InputError);
  options.branching = 1;
  EXPECT_THROW(TrainVocabulary({cv::Mat(4, 32, CV_8UC1, cv::Scalar(1))}, options), UsageError);
  options.branching = 8;
  options.levels = 0;
  EXPECT_THROW(options.Check(), UsageError);
  // A single distinct descriptor: one word (the root is the leaf).
  options.levels = 2;
  const Vocabulary one = TrainVocabulary({cv::Mat(5, 32, CV_8UC1, cv::Scalar(3))}, options);
  EXPECT_EQ(one.num_words(), 1);
  EXPECT_EQ(one.WordOf(cv::Mat(1, 32, CV_8UC1, cv::Scalar(200))), 0u);
  const fs::path path = Root() / "one.bin";
  one.Save(path);
  EXPECT_EQ(Vocabulary::Load(path).num_words(), 1);
}

// The default vocabulary (tools/make_default_vocabulary.sh, docs/loop-closure.md).
TEST(Vocabulary, DefaultOrbVocabularyLoadsWithTheDocumentedSize) {
  const fs::path path = fs::path(MCVO_SOURCE_DIR) / "config" / "vocabulary_orb.bin";
  ASSERT_TRUE(fs::exists(path)) << path;
  EXPECT_LT(fs::file_size(path), 400u * 1024u);
  const Vocabulary vocabulary = Vocabulary::Load(path);
  EXPECT_EQ(vocabulary.kind(), DescriptorKind::kBinary);
  EXPECT_EQ(vocabulary.descriptor_size(), 32);
  EXPECT_EQ(vocabulary.branching(), 8);
  EXPECT_EQ(vocabulary.levels(), 4);
  // A full tree: 1 + 8 + 64 + 512 + 4096 nodes, 36 + 4 x 4681 + 32 x 4680 + 8 x 4096 + 32 bytes.
  EXPECT_EQ(vocabulary.num_words(), 4096);
  EXPECT_EQ(vocabulary.num_nodes(), 4681);
  EXPECT_EQ(fs::file_size(path), 201320u);
  for (int w = 0; w < vocabulary.num_words(); ++w) EXPECT_GT(vocabulary.Idf(static_cast<uint32_t>(w)), 0.0);
  // It separates textured images: a noisy copy scores above an unrelated image.
  const cv::Mat image = TextureImage(900);
  cv::Mat copy = image.clone();
  cv::Mat noise(image.size(), CV_8UC1);
  cv::RNG(3).fill(noise, cv::RNG::UNIFORM, 0, 8);
  copy += noise;
  const BowVector bow = vocabulary.Transform(OrbDescriptors(image));
  EXPECT_GT(BowScore(bow, vocabulary.Transform(OrbDescriptors(copy))),
            2.0 * BowScore(bow, vocabulary.Transform(OrbDescriptors(TextureImage(901)))));
}

// `mcvo vocab` as a user runs it.
const fs::path& TinySequence() {
  static const fs::path seq = [] {
    const fs::path dir = Root() / "seq";
    const test::Result r = test::RunMcvo(
        "synth --preset stereo --frames 4 --image-scale 0.5 --samples 1 --out " + test::Quote(dir.string()));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return dir;
  }();
  return seq;
}

TEST(VocabCli, TrainsOnATinySequenceAndDescribesTheFile) {
  const fs::path out = Root() / "cli.bin";
  const std::string common = "vocab train --dataset " + test::Quote(TinySequence().string()) +
                             " --features 300 --branching 4 --levels 3 --frame-step 2 --seed 4 --out ";
  const test::Result r = test::RunMcvo(common + test::Quote(out.string()) + " --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("vocab train: 4 images (2 frames of 1 dataset)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" words (branching 4, levels 3)"), std::string::npos) << r.output;
  const Vocabulary vocabulary = Vocabulary::Load(out);
  EXPECT_EQ(vocabulary.kind(), DescriptorKind::kBinary);
  EXPECT_EQ(vocabulary.descriptor_size(), 32);
  EXPECT_GT(vocabulary.num_words(), 16);
  EXPECT_LE(vocabulary.num_words(), 64);
  // The same file at 2 threads.
  const fs::path out2 = Root() / "cli2.bin";
  const test::Result r2 = test::RunMcvo(common + test::Quote(out2.string()) + " --threads 2");
  ASSERT_EQ(r2.exit_code, 0) << r2.output;
  EXPECT_EQ(ReadFileToString(out2), ReadFileToString(out));

  const test::Result info = test::RunMcvo("vocab info " + test::Quote(out.string()));
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("kind: binary, 32-byte descriptors"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("words: " + std::to_string(vocabulary.num_words())), std::string::npos)
      << info.output;
}

TEST(VocabCli, BadDatasetPathExitsWith3AndWritesNothing) {
  const fs::path out = Root() / "never.bin";
  const fs::path missing = Root() / "no_such_dataset";
  const test::Result r = test::RunMcvo("vocab train --dataset " + test::Quote(missing.string()) + " --out " +
                                       test::Quote(out.string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find(missing.string()), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
  // Usage errors exit 2.
  EXPECT_EQ(test::RunMcvo("vocab train --dataset " + test::Quote(missing.string())).exit_code, 2);
  EXPECT_EQ(test::RunMcvo("vocab train --dataset x --out y --branching 1").exit_code, 2);
  EXPECT_EQ(test::RunMcvo("vocab train --dataset x --out y --descriptor xfeat").exit_code, 2);
  EXPECT_EQ(test::RunMcvo("vocab frobnicate").exit_code, 2);
  // A file that is not a vocabulary: exit 3, named.
  const fs::path junk = Root() / "junk.bin";
  WriteBytes(junk, "junk");
  const test::Result info = test::RunMcvo("vocab info " + test::Quote(junk.string()));
  EXPECT_EQ(info.exit_code, 3) << info.output;
  EXPECT_NE(info.output.find(junk.string()), std::string::npos) << info.output;
}

}  // namespace
}  // namespace mcvo
