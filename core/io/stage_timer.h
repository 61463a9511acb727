// Wall-clock laps of the pipeline's stages, in the order they ran, for
// result.json's timings_ms.
#pragma once

#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace dfsm {

class StageTimer {
 public:
  explicit StageTimer(std::vector<std::pair<std::string, double>>* timings)
      : timings_(timings), start_(std::chrono::steady_clock::now()) {}

  // Records the time since the previous lap (or construction) under `stage`.
  void Lap(const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    timings_->emplace_back(stage, std::chrono::duration<double, std::milli>(now - start_).count());
    start_ = now;
  }

 private:
  std::vector<std::pair<std::string, double>>* timings_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace dfsm
