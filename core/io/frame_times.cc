#include "core/io/frame_times.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace dfsm {
namespace {

// A timestamp interval this many median intervals long counts as more than
// one: a frame dropped between two frames doubles it, jitter moves it by far
// less than half.
constexpr double kGapIntervals = 1.5;

bool Increasing(const std::vector<int64_t>& values) {
  for (size_t i = 1; i < values.size(); ++i)
    if (values[i] <= values[i - 1]) return false;
  return values.size() >= 2;
}

// Times of consecutive frames are left empty: the model's default.
std::vector<double> UnlessConsecutive(std::vector<double> times) {
  for (size_t i = 0; i < times.size(); ++i)
    if (times[i] != static_cast<double>(i)) return times;
  return {};
}

}  // namespace

std::vector<double> CaptureTimes(const BurstManifest& manifest) {
  const size_t n = manifest.frames.size();
  std::vector<int64_t> sequence(n), timestamp(n);
  for (size_t i = 0; i < n; ++i) {
    sequence[i] = manifest.frames[i].sequence;
    timestamp[i] = manifest.frames[i].timestamp_ns;
  }
  std::vector<double> times(n);
  if (Increasing(sequence)) {
    for (size_t i = 0; i < n; ++i) times[i] = static_cast<double>(sequence[i] - sequence[0]);
    if (!UnlessConsecutive(times).empty()) return times;
  }
  if (!Increasing(timestamp)) return {};
  std::vector<double> intervals(n - 1);
  for (size_t i = 1; i < n; ++i)
    intervals[i - 1] = static_cast<double>(timestamp[i] - timestamp[i - 1]);
  std::vector<double> sorted = intervals;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  times[0] = 0.0;
  for (size_t i = 1; i < n; ++i) {
    const double steps =
        intervals[i - 1] < kGapIntervals * median ? 1.0 : std::round(intervals[i - 1] / median);
    times[i] = times[i - 1] + steps;
  }
  return UnlessConsecutive(std::move(times));
}

int MissingFrames(const std::vector<double>& times) {
  if (times.empty()) return 0;
  return static_cast<int>(std::lround(times.back() - times.front())) -
         (static_cast<int>(times.size()) - 1);
}

}  // namespace dfsm
