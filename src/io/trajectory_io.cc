// Trajectory readers and writers (TUM, KITTI, KITTI-indexed, EuRoC CSV).
// Formats: docs/trajectory-formats.md.
#include "mcvo/io/trajectory_io.h"

#include <Eigen/SVD>
#include <cmath>
#include <string>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

constexpr double kRotationTolerance = 1e-4;    // max |R^T R - I| of a KITTI rotation
constexpr double kQuaternionTolerance = 1e-3;  // max |1 - |q|| of a TUM/EuRoC quaternion

// One non-comment, non-blank line of a text file with its 1-based line number.
struct DataLine {
  int line_number = 0;
  std::string_view text;
};

// Splits `content` into data lines: blank lines and lines whose first
// non-blank character is '#' are skipped; a UTF-8 byte order mark is ignored.
std::vector<DataLine> DataLines(std::string_view content) {
  if (content.substr(0, 3) == "\xEF\xBB\xBF") content.remove_prefix(3);
  std::vector<DataLine> lines;
  int line_number = 0;
  size_t start = 0;
  while (start < content.size()) {
    size_t end = content.find('\n', start);
    if (end == std::string_view::npos) end = content.size();
    ++line_number;
    const std::string_view text = Trim(content.substr(start, end - start));
    if (!text.empty() && text.front() != '#') lines.push_back({line_number, text});
    start = end + 1;
  }
  return lines;
}

// Parses the fields of one line and reports errors as "<file>:<line>: ...".
class LineParser {
 public:
  LineParser(const std::string& source, const DataLine& line) : source_(source), line_(line) {}

  [[noreturn]] void Fail(const std::string& what) const {
    throw InputError(StrCat(source_, ":", line_.line_number, ": ", what));
  }

  double Number(std::string_view field, int column) const {
    const std::optional<double> value = ParseDouble(field);
    if (!value) Fail(StrCat("field ", column, ": expected a number, got '", field, "'"));
    if (!std::isfinite(*value))
      Fail(StrCat("field ", column, ": expected a finite number, got '", field, "'"));
    return *value;
  }

  int64_t Integer(std::string_view field, int column, const char* what) const {
    const std::optional<int64_t> value = ParseInt64(field);
    if (!value) Fail(StrCat("field ", column, ": expected ", what, " (an integer), got '", field, "'"));
    return *value;
  }

  void ExpectFieldCount(size_t got, size_t expected, const char* layout) const {
    if (got != expected) Fail(StrCat("expected ", expected, " fields (", layout, "), got ", got));
  }

  // Unit quaternion from w, x, y, z; normalised unless it already is to
  // rounding (so that written quaternions read back bit-exactly).
  Eigen::Quaterniond Quaternion(double w, double x, double y, double z) const {
    Eigen::Quaterniond q(w, x, y, z);
    const double norm = q.norm();
    if (std::abs(norm - 1.0) > kQuaternionTolerance) {
      Fail(StrCat("quaternion is not unit (norm ", FormatDouble(norm), ", tolerance ",
                  FormatDouble(kQuaternionTolerance), ")"));
    }
    if (std::abs(q.squaredNorm() - 1.0) > 1e-15) q.normalize();
    return q;
  }

  // Rotation from a row-major 3x3 block; checked and projected onto SO(3).
  Eigen::Quaterniond Rotation(const Eigen::Matrix3d& m) const {
    const double error = (m.transpose() * m - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (error > kRotationTolerance) {
      Fail(StrCat("rotation is not orthonormal (max |R^T R - I| = ", FormatDouble(error), ", tolerance ",
                  FormatDouble(kRotationTolerance), ")"));
    }
    if (m.determinant() <= 0.0)
      Fail(StrCat("rotation has determinant ", FormatDouble(m.determinant()), " <= 0"));
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
    return Eigen::Quaterniond(Eigen::Matrix3d(svd.matrixU() * svd.matrixV().transpose())).normalized();
  }

 private:
  const std::string& source_;
  const DataLine& line_;
};

Rigid3d PoseFrom3x4(const LineParser& parser, const std::vector<std::string_view>& fields, size_t first) {
  Eigen::Matrix<double, 3, 4> m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      const size_t i = first + static_cast<size_t>(4 * r + c);
      m(r, c) = parser.Number(fields[i], static_cast<int>(i) + 1);
    }
  }
  Rigid3d pose;
  pose.rotation = parser.Rotation(m.leftCols<3>());
  pose.translation = m.col(3);
  return pose;
}

StampedPose ParseTum(const LineParser& parser, const std::vector<std::string_view>& f) {
  parser.ExpectFieldCount(f.size(), 8, "t tx ty tz qx qy qz qw");
  StampedPose pose;
  const std::optional<int64_t> t_ns = ParseSecondsToNs(f[0]);
  if (!t_ns) parser.Fail(StrCat("field 1: expected a time in seconds, got '", f[0], "'"));
  pose.t_ns = *t_ns;
  double v[7];
  for (int i = 0; i < 7; ++i) v[i] = parser.Number(f[i + 1], i + 2);
  pose.world_from_body.translation = Eigen::Vector3d(v[0], v[1], v[2]);
  pose.world_from_body.rotation = parser.Quaternion(v[6], v[3], v[4], v[5]);
  return pose;
}

StampedPose ParseEuroc(const LineParser& parser, const std::vector<std::string_view>& f) {
  if (f.size() < 8) {
    parser.Fail(StrCat("expected at least 8 comma-separated fields (t_ns, px, py, pz, qw, qx, qy, qz), got ",
                       f.size()));
  }
  StampedPose pose;
  pose.t_ns = parser.Integer(f[0], 1, "a time in nanoseconds");
  double v[7];
  for (int i = 0; i < 7; ++i) v[i] = parser.Number(f[i + 1], i + 2);
  pose.world_from_body.translation = Eigen::Vector3d(v[0], v[1], v[2]);
  pose.world_from_body.rotation = parser.Quaternion(v[3], v[4], v[5], v[6]);
  return pose;
}

// KITTI-indexed: index + 12 numbers (poses.txt) or index + 16 numbers
// (cam0_to_world.txt, whose last row must be 0 0 0 1).
StampedPose ParseKittiIndexed(const LineParser& parser, const std::vector<std::string_view>& f) {
  if (f.size() != 13 && f.size() != 17) {
    parser.Fail(StrCat(
        "expected 13 fields (frame index + 12 numbers of a 3x4 matrix) or 17 (index + 4x4), got ", f.size()));
  }
  StampedPose pose;
  pose.frame_index = parser.Integer(f[0], 1, "a frame index");
  if (pose.frame_index < 0) parser.Fail(StrCat("field 1: frame index must be >= 0, got ", pose.frame_index));
  pose.world_from_body = PoseFrom3x4(parser, f, 1);
  if (f.size() == 17) {
    const double last[4] = {0.0, 0.0, 0.0, 1.0};
    for (int c = 0; c < 4; ++c) {
      if (parser.Number(f[13 + c], 14 + c) != last[c]) parser.Fail("last matrix row must be 0 0 0 1");
    }
  }
  return pose;
}

// Days since 1970-01-01 of a proleptic Gregorian date (civil calendar).
int64_t DaysFromCivil(int64_t year, int64_t month, int64_t day) {
  year -= month <= 2 ? 1 : 0;
  const int64_t era = (year >= 0 ? year : year - 399) / 400;
  const int64_t year_of_era = year - era * 400;
  const int64_t day_of_year = (153 * (month + (month > 2 ? -3 : 9)) + 2) / 5 + day - 1;
  const int64_t day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
  return era * 146097 + day_of_era - 719468;
}

// "YYYY-MM-DD HH:MM:SS[.fraction]" (KITTI-360 timestamps.txt, taken as UTC)
// to nanoseconds since the Unix epoch. Years outside 1678..2261 do not fit
// int64 nanoseconds and are no time (found by tests/fuzz/kitti360_calib_fuzz.cc).
std::optional<int64_t> ParseDateTimeToNs(std::string_view text) {
  const std::vector<std::string_view> parts = SplitTokens(text, " T");
  if (parts.size() != 2) return std::nullopt;
  const std::vector<std::string_view> date = SplitFields(parts[0], '-');
  const std::vector<std::string_view> clock = SplitFields(parts[1], ':');
  if (date.size() != 3 || clock.size() != 3) return std::nullopt;
  const std::optional<int64_t> year = ParseInt64(date[0]), month = ParseInt64(date[1]),
                               day = ParseInt64(date[2]);
  const std::optional<int64_t> hour = ParseInt64(clock[0]), minute = ParseInt64(clock[1]);
  const std::optional<int64_t> second_ns = ParseSecondsToNs(clock[2]);
  if (!year || !month || !day || !hour || !minute || !second_ns) return std::nullopt;
  if (*year < 1678 || *year > 2261 || *month < 1 || *month > 12 || *day < 1 || *day > 31 || *hour < 0 ||
      *hour > 23 || *minute < 0 || *minute > 59 || *second_ns < 0 || *second_ns >= 61'000'000'000LL) {
    return std::nullopt;
  }
  const int64_t seconds = DaysFromCivil(*year, *month, *day) * 86400 + *hour * 3600 + *minute * 60;
  return seconds * 1'000'000'000LL + *second_ns;
}

}  // namespace

std::optional<TrajectoryFormat> TrajectoryFormatFromName(std::string_view name) {
  if (name == "tum") return TrajectoryFormat::kTum;
  if (name == "kitti") return TrajectoryFormat::kKitti;
  if (name == "kitti-indexed" || name == "kitti360") return TrajectoryFormat::kKittiIndexed;
  if (name == "euroc") return TrajectoryFormat::kEuroc;
  return std::nullopt;
}

std::string_view TrajectoryFormatName(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kTum:
      return "tum";
    case TrajectoryFormat::kKitti:
      return "kitti";
    case TrajectoryFormat::kKittiIndexed:
      return "kitti-indexed";
    case TrajectoryFormat::kEuroc:
      return "euroc";
  }
  MCVO_CHECK(false);
  return "";
}

TrajectoryFormat DetectTrajectoryFormat(const std::filesystem::path& path) {
  return DetectTrajectoryFormatFromText(ReadFileToString(path), path.string());
}

TrajectoryFormat DetectTrajectoryFormatFromText(const std::string& content, const std::string& source) {
  const std::vector<DataLine> lines = DataLines(content);
  if (lines.empty()) MCVO_THROW_INPUT(source, ": no data lines, cannot detect the trajectory format");
  const DataLine& first = lines.front();
  if (first.text.find(',') != std::string_view::npos) return TrajectoryFormat::kEuroc;
  const std::vector<std::string_view> fields = SplitTokens(first.text);
  if (fields.size() == 8) return TrajectoryFormat::kTum;
  if (fields.size() == 12) return TrajectoryFormat::kKitti;
  if ((fields.size() == 13 || fields.size() == 17) && ParseInt64(fields[0]))
    return TrajectoryFormat::kKittiIndexed;
  MCVO_THROW_INPUT(source, ":", first.line_number, ": cannot detect the trajectory format from ",
                   fields.size(),
                   " fields (expected 8 for TUM, 12 for KITTI, 13 or 17 with a leading frame index for "
                   "KITTI-360, or comma-separated EuRoC)");
}

Trajectory ReadTrajectory(const std::filesystem::path& path, TrajectoryFormat format) {
  return ParseTrajectory(ReadFileToString(path), path.string(), format);
}

Trajectory ParseTrajectory(const std::string& content, const std::string& source, TrajectoryFormat format) {
  const std::vector<DataLine> lines = DataLines(content);
  Trajectory trajectory;
  trajectory.has_time = format == TrajectoryFormat::kTum || format == TrajectoryFormat::kEuroc;
  trajectory.has_frame_index =
      format == TrajectoryFormat::kKitti || format == TrajectoryFormat::kKittiIndexed;
  trajectory.poses.reserve(lines.size());
  for (const DataLine& line : lines) {
    const LineParser parser(source, line);
    StampedPose pose;
    switch (format) {
      case TrajectoryFormat::kTum:
        pose = ParseTum(parser, SplitTokens(line.text));
        break;
      case TrajectoryFormat::kEuroc:
        pose = ParseEuroc(parser, SplitFields(line.text, ','));
        break;
      case TrajectoryFormat::kKitti: {
        const std::vector<std::string_view> fields = SplitTokens(line.text);
        parser.ExpectFieldCount(fields.size(), 12, "row-major 3x4 world_from_body");
        pose.world_from_body = PoseFrom3x4(parser, fields, 0);
        pose.frame_index = static_cast<int64_t>(trajectory.poses.size());
        break;
      }
      case TrajectoryFormat::kKittiIndexed:
        pose = ParseKittiIndexed(parser, SplitTokens(line.text));
        break;
    }
    if (!trajectory.poses.empty()) {
      const StampedPose& previous = trajectory.poses.back();
      if (trajectory.has_time && pose.t_ns <= previous.t_ns) {
        parser.Fail(pose.t_ns == previous.t_ns
                        ? StrCat("duplicate time ", FormatNsAsSeconds(pose.t_ns), " s")
                        : StrCat("time goes backwards (", FormatNsAsSeconds(pose.t_ns), " s after ",
                                 FormatNsAsSeconds(previous.t_ns), " s)"));
      }
      if (format == TrajectoryFormat::kKittiIndexed && pose.frame_index <= previous.frame_index) {
        parser.Fail(pose.frame_index == previous.frame_index
                        ? StrCat("duplicate frame index ", pose.frame_index)
                        : StrCat("frame index goes backwards (", pose.frame_index, " after ",
                                 previous.frame_index, ")"));
      }
    }
    trajectory.poses.push_back(pose);
  }
  return trajectory;
}

void ApplyTimesFile(const std::filesystem::path& times_path, Trajectory* trajectory) {
  MCVO_CHECK(trajectory != nullptr);
  if (!trajectory->has_frame_index) {
    MCVO_THROW_INPUT(times_path.string(), ": the trajectory has no frame indices to look times up by");
  }
  const std::string content = ReadFileToString(times_path);
  const std::vector<DataLine> lines = DataLines(content);
  std::vector<int64_t> times;
  times.reserve(lines.size());
  for (const DataLine& line : lines) {
    std::optional<int64_t> t_ns = ParseSecondsToNs(line.text);
    if (!t_ns) t_ns = ParseDateTimeToNs(line.text);
    if (!t_ns) {
      MCVO_THROW_INPUT(times_path.string(), ":", line.line_number,
                       ": expected a time in seconds or 'YYYY-MM-DD HH:MM:SS.fraction', got '", line.text,
                       "'");
    }
    if (!times.empty() && *t_ns <= times.back()) {
      MCVO_THROW_INPUT(times_path.string(), ":", line.line_number, ": time ", FormatNsAsSeconds(*t_ns),
                       " s is not after the previous one (", FormatNsAsSeconds(times.back()), " s)");
    }
    times.push_back(*t_ns);
  }
  for (StampedPose& pose : trajectory->poses) {
    if (pose.frame_index < 0 || pose.frame_index >= static_cast<int64_t>(times.size())) {
      MCVO_THROW_INPUT(times_path.string(), ": has ", times.size(),
                       " times, but the trajectory has frame index ", pose.frame_index);
    }
    pose.t_ns = times[static_cast<size_t>(pose.frame_index)];
  }
  trajectory->has_time = true;
}

void WriteTrajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                     TrajectoryFormat format) {
  const bool needs_time = format == TrajectoryFormat::kTum || format == TrajectoryFormat::kEuroc;
  if (needs_time && !trajectory.has_time) {
    MCVO_THROW_INPUT(path.string(), ": cannot write ", TrajectoryFormatName(format),
                     ": the trajectory has no time stamps (give a times file)");
  }
  std::string out;
  if (format == TrajectoryFormat::kTum) out += "# timestamp tx ty tz qx qy qz qw\n";
  if (format == TrajectoryFormat::kEuroc) {
    out += "#timestamp [ns],p_x [m],p_y [m],p_z [m],q_w [],q_x [],q_y [],q_z []\n";
  }
  for (size_t i = 0; i < trajectory.poses.size(); ++i) {
    const StampedPose& pose = trajectory.poses[i];
    const Eigen::Vector3d& t = pose.world_from_body.translation;
    const Eigen::Quaterniond& q = pose.world_from_body.rotation;
    switch (format) {
      case TrajectoryFormat::kTum:
        out += StrCat(FormatNsAsSeconds(pose.t_ns), " ", FormatDouble(t.x()), " ", FormatDouble(t.y()), " ",
                      FormatDouble(t.z()), " ", FormatDouble(q.x()), " ", FormatDouble(q.y()), " ",
                      FormatDouble(q.z()), " ", FormatDouble(q.w()), "\n");
        break;
      case TrajectoryFormat::kEuroc:
        out += StrCat(pose.t_ns, ",", FormatDouble(t.x()), ",", FormatDouble(t.y()), ",", FormatDouble(t.z()),
                      ",", FormatDouble(q.w()), ",", FormatDouble(q.x()), ",", FormatDouble(q.y()), ",",
                      FormatDouble(q.z()), "\n");
        break;
      case TrajectoryFormat::kKitti:
      case TrajectoryFormat::kKittiIndexed: {
        if (format == TrajectoryFormat::kKittiIndexed) {
          out += StrCat(trajectory.has_frame_index ? pose.frame_index : static_cast<int64_t>(i), " ");
        }
        const Eigen::Matrix<double, 3, 4> m = pose.world_from_body.ToMatrix3x4();
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 4; ++c) out += FormatDouble(m(r, c)) + (r == 2 && c == 3 ? "\n" : " ");
        }
        break;
      }
    }
  }
  WriteFileAtomic(path, out);
}

}  // namespace mcvo
