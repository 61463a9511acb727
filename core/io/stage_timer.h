// Wall-clock laps of the pipeline's stages, in the order they ran, for
// result.json's timings_ms.
#pragma once

#include <algorithm>
#include <chrono>
#include <string>
#include <utility>
#include <vector>

#include "core/io/progress.h"

namespace dfsm {

// Milliseconds from `from` to `to` (default: now), as timings_ms reports them.
inline double MillisecondsBetween(
    std::chrono::steady_clock::time_point from,
    std::chrono::steady_clock::time_point to = std::chrono::steady_clock::now()) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

class StageTimer {
 public:
  // `progress` (may be empty) hears of each lap as it ends.
  explicit StageTimer(std::vector<std::pair<std::string, double>>* timings,
                      ProgressCallback progress = {})
      : timings_(timings),
        progress_(std::move(progress)),
        start_(std::chrono::steady_clock::now()) {}

  // Records the time since the previous lap (or construction) under `stage`,
  // less `carried_ms` of it, which goes to the next lap instead: time this
  // stage spent waiting for work that ran beside it and is timed as its own.
  // A stage that runs again (a fallback repeats the starts) adds to its first
  // lap: timings_ms names each stage once, and a second entry would hide the
  // first wherever the laps become a JSON object.
  void Lap(const std::string& stage, double carried_ms = 0.0) {
    const auto now = std::chrono::steady_clock::now();
    const double elapsed_ms = MillisecondsBetween(start_, now);
    carried_ms = std::clamp(carried_ms, 0.0, elapsed_ms);
    const auto same = std::find_if(timings_->begin(), timings_->end(),
                                   [&](const auto& lap) { return lap.first == stage; });
    if (same == timings_->end())
      timings_->emplace_back(stage, elapsed_ms - carried_ms);
    else
      same->second += elapsed_ms - carried_ms;
    start_ = now - std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                       std::chrono::duration<double, std::milli>(carried_ms));
    ReportProgress(progress_, stage, 1, 1);
  }

 private:
  std::vector<std::pair<std::string, double>>* timings_;
  ProgressCallback progress_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace dfsm
