// Small generic-format datasets for the dataset tests, rendered by
// synth::Synthesize (tiny images, one sample per pixel) into temporary folders,
// and helpers to break them in controlled ways.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "mcvo/dataset/dataset.h"
#include "mcvo/synth/synthesize.h"
#include "test_temp_dir.h"

namespace mcvo::testing {

namespace fs = std::filesystem;

// A rendered sequence of `preset` with `frames` frames, made once per test
// binary and cached; tests copy it before changing anything.
inline fs::path SynthDataset(const std::string& suite, const std::string& preset, int frames) {
  static std::map<std::string, fs::path> cache;
  const std::string key = preset + "_" + std::to_string(frames);
  const auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  const fs::path out = TestTempDir(suite) / ("pristine_" + key);
  fs::remove_all(out);
  synth::SynthOptions options;
  options.preset = preset;
  options.frames = frames;
  options.image_scale = 0.1;
  options.seed = 3;
  options.render.samples_per_axis = 1;
  options.render.threads = 1;
  options.render.seed = 3;
  synth::Synthesize(options, out);
  cache[key] = out;
  return out;
}

// A fresh, writable copy of a dataset named `name`.
inline fs::path CopyDataset(const fs::path& source, const std::string& suite, const std::string& name) {
  const fs::path out = TestTempDir(suite) / name;
  fs::remove_all(out);
  fs::copy(source, out, fs::copy_options::recursive);
  return out;
}

inline std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

inline void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

inline std::vector<std::string> ReadLines(const fs::path& path) {
  std::vector<std::string> lines;
  std::istringstream in(ReadText(path));
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

inline void WriteLines(const fs::path& path, const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  WriteText(path, text);
}

// Replaces field `field` (0 = t_ns) of line `line` (0 = header) of a CSV file.
inline void SetCsvField(const fs::path& path, size_t line, size_t field, const std::string& value) {
  std::vector<std::string> lines = ReadLines(path);
  std::vector<std::string> fields;
  std::string current;
  for (char c : lines.at(line)) {
    if (c == ',') {
      fields.push_back(current);
      current.clear();
    } else {
      current += c;
    }
  }
  fields.push_back(current);
  fields.at(field) = value;
  std::string joined;
  for (size_t i = 0; i < fields.size(); ++i) joined += (i > 0 ? "," : "") + fields[i];
  lines[line] = joined;
  WriteLines(path, lines);
}

// True when a line of the reader's log contains `text`.
inline bool LogHas(const DatasetIndex& index, const std::string& text) {
  for (const std::string& line : index.log) {
    if (line.find(text) != std::string::npos) return true;
  }
  return false;
}

}  // namespace mcvo::testing
