#include "mcvo/io/trajectory_io.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

std::filesystem::path TempDir() {
  const char* env = std::getenv("MCVO_TEST_TMP");
  std::filesystem::path dir =
      env != nullptr ? std::filesystem::path(env) : std::filesystem::path(::testing::TempDir());
  dir /= "trajectory_io_test";
  std::filesystem::create_directories(dir);
  return dir;
}

std::filesystem::path WriteTemp(const std::string& name, const std::string& content) {
  const std::filesystem::path path = TempDir() / name;
  WriteFileAtomic(path, content);
  return path;
}

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

Trajectory MakeTrajectory(bool with_time, bool with_index) {
  Trajectory trajectory;
  trajectory.has_time = with_time;
  trajectory.has_frame_index = with_index;
  for (int i = 0; i < 20; ++i) {
    StampedPose pose;
    pose.t_ns = with_time ? 1369123456789LL + 33333333LL * i + (i % 3) : 0;
    pose.frame_index = with_index ? 3 * i + 1 : -1;
    const Eigen::Vector3d axis = Eigen::Vector3d(1.0 / 3.0, -0.7 + 0.05 * i, 0.2).normalized();
    pose.world_from_body.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.1 + 0.37 * i, axis)).normalized();
    pose.world_from_body.translation = Eigen::Vector3d(i / 7.0, -1e-9 * i, 1234.5678 + 0.1 * i);
    trajectory.poses.push_back(pose);
  }
  return trajectory;
}

// Writes, reads back and writes again: same poses, same bytes.
void ExpectRoundTrip(TrajectoryFormat format, bool with_time, bool with_index, bool rotation_bit_exact) {
  SCOPED_TRACE(std::string(TrajectoryFormatName(format)));
  const Trajectory original = MakeTrajectory(with_time, with_index);
  const std::filesystem::path first = TempDir() / ("first." + std::string(TrajectoryFormatName(format)));
  const std::filesystem::path second = TempDir() / ("second." + std::string(TrajectoryFormatName(format)));
  WriteTrajectory(first, original, format);
  EXPECT_EQ(DetectTrajectoryFormat(first), format);
  const Trajectory read = ReadTrajectory(first, format);
  ASSERT_EQ(read.poses.size(), original.poses.size());
  for (size_t i = 0; i < read.poses.size(); ++i) {
    const StampedPose& a = original.poses[i];
    const StampedPose& b = read.poses[i];
    if (with_time) {
      EXPECT_EQ(a.t_ns, b.t_ns);
    }
    if (format == TrajectoryFormat::kKittiIndexed) {
      EXPECT_EQ(a.frame_index, b.frame_index);
    }
    if (format == TrajectoryFormat::kKitti) {
      EXPECT_EQ(b.frame_index, static_cast<int64_t>(i));
    }
    // Exact values (FormatDouble writes -0 as 0, so compare values, not bits).
    EXPECT_EQ(a.world_from_body.translation, b.world_from_body.translation);
    for (int k = 0; k < 4; ++k) {
      const double qa = a.world_from_body.rotation.coeffs()[k];
      const double qb = b.world_from_body.rotation.coeffs()[k];
      if (rotation_bit_exact) {
        EXPECT_TRUE(SameBits(qa, qb)) << i << " " << k << ": " << qa << " vs " << qb;
      }
    }
    // Rotation matrices (sign-free) agree to rounding.
    EXPECT_LT((a.world_from_body.RotationMatrix() - b.world_from_body.RotationMatrix()).cwiseAbs().maxCoeff(),
              1e-15);
  }
  WriteTrajectory(second, read, format);
  if (rotation_bit_exact) {
    EXPECT_EQ(ReadFileToString(first), ReadFileToString(second));
  }
}

TEST(TrajectoryIo, TumRoundTripIsBitExact) { ExpectRoundTrip(TrajectoryFormat::kTum, true, false, true); }
TEST(TrajectoryIo, EurocRoundTripIsBitExact) { ExpectRoundTrip(TrajectoryFormat::kEuroc, true, false, true); }
// KITTI stores rotation matrices and Rigid3d a quaternion: the matrix goes
// through a quaternion, so rotations agree to 1e-15, translations bit for bit.
TEST(TrajectoryIo, KittiRoundTrip) { ExpectRoundTrip(TrajectoryFormat::kKitti, false, true, false); }
TEST(TrajectoryIo, KittiIndexedRoundTrip) {
  ExpectRoundTrip(TrajectoryFormat::kKittiIndexed, false, true, false);
}

TEST(TrajectoryIo, TumTimesAreExactNanoseconds) {
  const std::filesystem::path path =
      WriteTemp("times.tum", "# comment\n\n1369.123456789 0 0 0 0 0 0 1\n1369.2 1 2 3 0 0 0 1\n");
  const Trajectory trajectory = ReadTrajectory(path, TrajectoryFormat::kTum);
  ASSERT_EQ(trajectory.poses.size(), 2u);
  EXPECT_EQ(trajectory.poses[0].t_ns, 1369123456789LL);
  EXPECT_EQ(trajectory.poses[1].t_ns, 1369200000000LL);
  EXPECT_TRUE(trajectory.has_time);
  EXPECT_FALSE(trajectory.has_frame_index);
}

TEST(TrajectoryIo, NamesAndDetection) {
  EXPECT_EQ(TrajectoryFormatFromName("kitti360"), TrajectoryFormat::kKittiIndexed);
  EXPECT_EQ(TrajectoryFormatFromName("kitti-indexed"), TrajectoryFormat::kKittiIndexed);
  EXPECT_EQ(TrajectoryFormatFromName("euroc"), TrajectoryFormat::kEuroc);
  EXPECT_FALSE(TrajectoryFormatFromName("csv").has_value());
  for (TrajectoryFormat f : {TrajectoryFormat::kTum, TrajectoryFormat::kKitti,
                             TrajectoryFormat::kKittiIndexed, TrajectoryFormat::kEuroc}) {
    EXPECT_EQ(TrajectoryFormatFromName(TrajectoryFormatName(f)), f);
  }
  const std::filesystem::path bad = WriteTemp("bad_detect.txt", "# header\n1 2 3 4 5\n");
  try {
    DetectTrajectoryFormat(bad);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(bad.string() + ":2: cannot detect"), std::string::npos) << e.what();
  }
  EXPECT_THROW(DetectTrajectoryFormat(WriteTemp("empty.txt", "# nothing\n")), InputError);
}

// A KITTI-360 data_poses/<seq>/poses.txt snippet: sparse frame indices, 10 decimals.
constexpr char kKitti360Poses[] =
    "3 0.0371783278 -0.0986182135 0.9944306009 1.5752681039 0.9992675562 -0.0053553387 -0.0378902567 "
    "0.0043914093 0.0090621821 0.9951109327 0.0983468786 -0.6500000000\n"
    "4 0.0194000864 -0.1051529641 0.9942668106 2.5977241400 0.9997374956 -0.0100836652 -0.0205732716 "
    "0.5981494900 0.0121891942 0.9944049345 0.1049297370 -0.6488433108\n"
    "7 0.9995185086 0.0041276589 -0.0307524527 4.7264036936 -0.0307926666 0.0100608424 -0.9994751579 "
    "-0.1499658517 -0.0038160970 0.9999408692 0.0101830998 -1.0686400091\n";

TEST(TrajectoryIo, ReadsKitti360PosesAndTimestamps) {
  const std::filesystem::path path = WriteTemp("poses.txt", kKitti360Poses);
  ASSERT_EQ(DetectTrajectoryFormat(path), TrajectoryFormat::kKittiIndexed);
  Trajectory trajectory = ReadTrajectory(path, TrajectoryFormat::kKittiIndexed);
  ASSERT_EQ(trajectory.poses.size(), 3u);
  EXPECT_EQ(trajectory.poses[0].frame_index, 3);
  EXPECT_EQ(trajectory.poses[2].frame_index, 7);
  EXPECT_EQ(trajectory.poses[1].world_from_body.translation.x(), 2.5977241400);
  EXPECT_NEAR(trajectory.poses[2].world_from_body.RotationMatrix()(1, 2), -0.9994751579, 1e-9);
  EXPECT_FALSE(trajectory.has_time);

  // KITTI-360 timestamps.txt: wall-clock times, line i = frame i.
  std::string times;
  for (int i = 0; i < 8; ++i) times += "2013-05-28 08:46:02." + std::to_string(100000000 + 1000 * i) + "\n";
  ApplyTimesFile(WriteTemp("timestamps.txt", times), &trajectory);
  EXPECT_TRUE(trajectory.has_time);
  // 2013-05-28 08:46:02 UTC = 1369730762 s after the epoch.
  EXPECT_EQ(trajectory.poses[0].t_ns, 1369730762LL * 1000000000LL + 100003000LL);
  EXPECT_EQ(trajectory.poses[2].t_ns - trajectory.poses[0].t_ns, 4000);

  // KITTI times.txt: seconds, scientific notation allowed.
  ApplyTimesFile(WriteTemp("times.txt", "0.000000e+00\n1.0e-01\n2e-1\n0.3\n0.4\n0.5\n0.6\n7.000000e-01\n"),
                 &trajectory);
  EXPECT_EQ(trajectory.poses[0].t_ns, 300000000);
  EXPECT_EQ(trajectory.poses[2].t_ns, 700000000);

  // A frame without a time, and times that do not increase.
  EXPECT_THROW(ApplyTimesFile(WriteTemp("short.txt", "0\n0.1\n"), &trajectory), InputError);
  try {
    ApplyTimesFile(WriteTemp("backwards.txt", "0\n0.2\n0.1\n"), &trajectory);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("backwards.txt:3:"), std::string::npos) << e.what();
  }
}

// Found by tests/fuzz/kitti360_calib_fuzz.cc: a year whose time does not fit
// int64 nanoseconds overflowed; now it is an error naming the file and line.
TEST(TrajectoryIo, TimesOutsideInt64NanosecondsAreErrors) {
  Trajectory trajectory;
  trajectory.has_frame_index = true;
  trajectory.poses.resize(2);
  trajectory.poses[0].frame_index = 0;
  trajectory.poses[1].frame_index = 1;
  ApplyTimesFile(WriteTemp("range.txt", "1678-01-01 00:00:00\n2261-12-31 23:59:59.999999999\n"), &trajectory);
  EXPECT_EQ(trajectory.poses[0].t_ns, -9214560000LL * 1000000000LL);
  for (const std::string& times : {std::string("20113-05-28 08:46:02.223456789\n2013-05-28 08:46:02\n"),
                                   std::string("1677-12-31 23:59:59\n2013-05-28 08:46:02\n"),
                                   std::string("9223372036.854775808\n9223372037\n")}) {
    try {
      ApplyTimesFile(WriteTemp("out_of_range.txt", times), &trajectory);
      ADD_FAILURE() << "no InputError for " << times;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("out_of_range.txt:1: expected a time"), std::string::npos)
          << e.what();
    }
  }
}

TEST(TrajectoryIo, ReadsKitti360Cam0ToWorld) {
  const std::filesystem::path path = WriteTemp(
      "cam0_to_world.txt", "5 1 0 0 1.5 0 1 0 2.5 0 0 1 3.5 0 0 0 1\n9 1 0 0 2 0 1 0 3 0 0 1 4 0 0 0 1\n");
  ASSERT_EQ(DetectTrajectoryFormat(path), TrajectoryFormat::kKittiIndexed);
  const Trajectory trajectory = ReadTrajectory(path, TrajectoryFormat::kKittiIndexed);
  ASSERT_EQ(trajectory.poses.size(), 2u);
  EXPECT_EQ(trajectory.poses[1].frame_index, 9);
  EXPECT_EQ(trajectory.poses[0].world_from_body.translation, Eigen::Vector3d(1.5, 2.5, 3.5));
}

// EuRoC state_groundtruth_estimate0/data.csv: 17 columns (p, q, v, bw, ba).
constexpr char kEurocGroundTruth[] =
    "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
    "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], "
    "b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]\n"
    "1403636580838555648,4.688319,-1.786938,0.783338,0.534108,-0.153029,-0.827383,-0.082152,-0.027876,"
    "0.033207,0.800006,-0.003172,0.021267,0.078502,-0.025266,0.136696,0.075593\n"
    "1403636580843555328,4.688177,-1.786770,0.787350,0.534640,-0.152990,-0.826976,-0.082863,-0.029272,"
    "0.033992,0.804406,-0.003172,0.021267,0.078502,-0.025266,0.136696,0.075593\n";

TEST(TrajectoryIo, ReadsEurocGroundTruthWith17Columns) {
  const std::filesystem::path path = WriteTemp("data.csv", kEurocGroundTruth);
  ASSERT_EQ(DetectTrajectoryFormat(path), TrajectoryFormat::kEuroc);
  const Trajectory trajectory = ReadTrajectory(path, TrajectoryFormat::kEuroc);
  ASSERT_EQ(trajectory.poses.size(), 2u);
  EXPECT_EQ(trajectory.poses[0].t_ns, 1403636580838555648LL);
  EXPECT_EQ(trajectory.poses[1].world_from_body.translation.z(), 0.787350);
  // w first in EuRoC.
  EXPECT_NEAR(trajectory.poses[0].world_from_body.rotation.w(), 0.534108, 1e-6);
  EXPECT_NEAR(trajectory.poses[0].world_from_body.rotation.z(), -0.082152, 1e-6);
}

TEST(TrajectoryIo, WritingTumWithoutTimesIsAnError) {
  EXPECT_THROW(
      WriteTrajectory(TempDir() / "no_times.tum", MakeTrajectory(false, true), TrajectoryFormat::kTum),
      InputError);
}

struct MalformedCase {
  TrajectoryFormat format;
  std::string content;
  int line;
  std::string expected;  // part of the message
};

TEST(TrajectoryIo, MalformedLinesNameFileAndLine) {
  const std::string ok_tum = "1.0 0 0 0 0 0 0 1\n";
  const std::string ok_kitti = "1 0 0 0 0 1 0 0 0 0 1 0\n";
  const std::vector<MalformedCase> cases = {
      {TrajectoryFormat::kTum, "# c\n" + ok_tum + "2.0 0 0 0 0 0 1\n", 3, "expected 8 fields"},
      {TrajectoryFormat::kTum, ok_tum + "\n2.0 0 x 0 0 0 0 1\n", 3, "field 3: expected a number, got 'x'"},
      {TrajectoryFormat::kTum, ok_tum + "2.0 0 nan 0 0 0 0 1\n", 2, "expected a finite number"},
      {TrajectoryFormat::kTum, ok_tum + "2.0 inf 0 0 0 0 0 1\n", 2, "expected a finite number"},
      {TrajectoryFormat::kTum, ok_tum + "abc 0 0 0 0 0 0 1\n", 2, "expected a time in seconds"},
      {TrajectoryFormat::kTum, ok_tum + "2.0 0 0 0 0 0 0 1.1\n", 2, "quaternion is not unit"},
      {TrajectoryFormat::kTum, ok_tum + "0.5 0 0 0 0 0 0 1\n", 2, "time goes backwards"},
      {TrajectoryFormat::kTum, ok_tum + "1.000000000 0 0 0 0 0 0 1\n", 2, "duplicate time"},
      {TrajectoryFormat::kKitti, ok_kitti + ok_kitti + "1 0 0 0 0 1 0 0 0 0 1\n", 3, "expected 12 fields"},
      {TrajectoryFormat::kKitti, ok_kitti + "1 0 0 0 0 1.01 0 0 0 0 1 0\n", 2, "rotation is not orthonormal"},
      {TrajectoryFormat::kKitti, ok_kitti + "-1 0 0 0 0 1 0 0 0 0 1 0\n", 2, "determinant"},
      {TrajectoryFormat::kKitti, "\n\n" + ok_kitti + "1 0 0 0 0 1 0 0 0 0 1 1e999\n", 4,
       "expected a finite number"},
      {TrajectoryFormat::kKittiIndexed, "0 " + ok_kitti + "0 " + ok_kitti, 2, "duplicate frame index 0"},
      {TrajectoryFormat::kKittiIndexed, "5 " + ok_kitti + "4 " + ok_kitti, 2, "frame index goes backwards"},
      {TrajectoryFormat::kKittiIndexed, "0.5 " + ok_kitti, 1, "expected a frame index"},
      {TrajectoryFormat::kKittiIndexed, ok_kitti, 1, "expected 13 fields"},
      {TrajectoryFormat::kEuroc, "#t\n1,0,0,0,1,0,0,0\n2,0,0,0,1,0,0\n", 3, "expected at least 8"},
      {TrajectoryFormat::kEuroc, "#t\n1.5,0,0,0,1,0,0,0\n", 2, "a time in nanoseconds"},
      {TrajectoryFormat::kEuroc, "#t\n1,0,0,0,1,0,0,0\n1,0,0,0,1,0,0,0\n", 3, "duplicate time"},
      {TrajectoryFormat::kEuroc, "#t\n1,0,,0,1,0,0,0\n", 2, "field 3: expected a number"},
      {TrajectoryFormat::kEuroc, "#t\n1,0,0,0,0.5,0,0,0\n", 2, "quaternion is not unit"},
      // Found by tests/fuzz/trajectory_fuzz.cc: times beyond int64 nanoseconds overflowed.
      {TrajectoryFormat::kTum, ok_tum + "9223372036.8547758077 1 0 0 0  0 1 0\n", 2,
       "expected a time in seconds"},
      {TrajectoryFormat::kTum, ok_tum + "9999999999 0 0 0 0 0 0 1\n", 2, "expected a time in seconds"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const MalformedCase& c = cases[i];
    const std::filesystem::path path = WriteTemp("malformed_" + std::to_string(i) + ".txt", c.content);
    try {
      ReadTrajectory(path, c.format);
      ADD_FAILURE() << "case " << i << ": expected InputError";
    } catch (const InputError& e) {
      const std::string what = e.what();
      const std::string prefix = path.string() + ":" + std::to_string(c.line) + ": ";
      EXPECT_EQ(what.rfind(prefix, 0), 0u) << "case " << i << ": " << what;
      EXPECT_NE(what.find(c.expected), std::string::npos) << "case " << i << ": " << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << "case " << i;
    }
  }
}

}  // namespace
}  // namespace mcvo
