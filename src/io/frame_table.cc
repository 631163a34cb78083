#include "mcvo/io/frame_table.h"

#include <set>
#include <sstream>
#include <string_view>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo {

void WriteFrameTable(const std::filesystem::path& path, const FrameTable& table) {
  AtomicFileWriter writer(path);
  std::ostream& out = writer.stream();
  out << "t_ns";
  for (const std::string& name : table.camera_names) out << ',' << name;
  out << '\n';
  for (const FrameTableRow& row : table.rows) {
    MCVO_CHECK(row.image_paths.size() == table.camera_names.size());
    out << row.t_ns;
    for (const std::string& image : row.image_paths) out << ',' << image;
    out << '\n';
  }
  writer.Commit();
}

FrameTable ReadFrameTable(const std::filesystem::path& path) {
  return ParseFrameTable(ReadFileToString(path), path.string());
}

FrameTable ParseFrameTable(const std::string& text, const std::string& file) {
  // A UTF-8 byte order mark (spreadsheet exports write one) is not part of
  // the header, as in rig.json and groundtruth.tum.
  constexpr std::string_view kBom = "\xEF\xBB\xBF";
  std::istringstream in(std::string_view(text).substr(0, kBom.size()) == kBom ? text.substr(kBom.size())
                                                                              : text);
  std::string line;
  int line_number = 0;
  FrameTable table;
  bool have_header = false;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string_view trimmed = Trim(line);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    const std::vector<std::string_view> fields = SplitFields(trimmed, ',');
    if (!have_header) {
      if (fields.size() < 2 || fields[0] != "t_ns") {
        MCVO_THROW_INPUT(file, ":", line_number, ": expected the header \"t_ns,<camera name>,...\"");
      }
      std::set<std::string_view> seen;
      for (size_t i = 1; i < fields.size(); ++i) {
        if (fields[i].empty())
          MCVO_THROW_INPUT(file, ":", line_number, ": empty camera name in column ", i + 1);
        if (!seen.insert(fields[i]).second) {
          MCVO_THROW_INPUT(file, ":", line_number, ": camera name \"", EscapeForMessage(fields[i]),
                           "\" appears twice");
        }
        table.camera_names.emplace_back(fields[i]);
      }
      have_header = true;
      continue;
    }
    if (fields.size() != table.camera_names.size() + 1) {
      MCVO_THROW_INPUT(file, ":", line_number, ": expected ", table.camera_names.size() + 1,
                       " comma-separated fields (t_ns and one image per camera), got ", fields.size());
    }
    FrameTableRow row;
    const std::optional<int64_t> t_ns = ParseInt64(fields[0]);
    if (!t_ns)
      MCVO_THROW_INPUT(file, ":", line_number, ": t_ns must be an integer (nanoseconds), got \"",
                       EscapeForMessage(fields[0]), "\"");
    row.t_ns = *t_ns;
    if (!table.rows.empty() && row.t_ns <= table.rows.back().t_ns) {
      MCVO_THROW_INPUT(file, ":", line_number, ": time ", row.t_ns, " ns does not increase (previous ",
                       table.rows.back().t_ns, " ns)");
    }
    for (size_t i = 1; i < fields.size(); ++i) {
      if (fields[i].find_first_of(" \t") != std::string_view::npos) {
        MCVO_THROW_INPUT(file, ":", line_number, ": image path \"", EscapeForMessage(fields[i]),
                         "\" contains a blank");
      }
      row.image_paths.emplace_back(fields[i]);
    }
    table.rows.push_back(std::move(row));
  }
  if (!have_header)
    MCVO_THROW_INPUT(file, ": empty frame table (expected the header \"t_ns,<camera name>,...\")");
  return table;
}

}  // namespace mcvo
