// A progress bar on stderr when stderr is a terminal; silent otherwise (batch
// jobs and CI logs get no carriage-return noise). Never touches outputs.
#pragma once

#include <chrono>
#include <string>

namespace mcvo {

class ProgressBar {
 public:
  // `total` units of work, named `unit` ("frames").
  ProgressBar(std::string label, int64_t total, std::string unit);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void SetTotal(int64_t total) { total_ = total; }
  // Marks `done` units complete (monotonic). Redraws at most 10 times a second.
  void Update(int64_t done);
  // Draws the final state and ends the line.
  void Finish();
  bool enabled() const { return enabled_; }
  double ElapsedSeconds() const;

 private:
  void Draw(bool force);
  std::string label_;
  std::string unit_;
  int64_t total_ = 0;
  int64_t done_ = 0;
  bool enabled_ = false;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace mcvo
