#include "core/pipeline/repeated_frames.h"

#include <algorithm>
#include <stdexcept>

namespace dfsm {

void RepeatedFramesOptions::Check() const {
  if (!(max_ratio >= 0.0 && max_ratio < 1.0))
    throw std::invalid_argument("repeated frames: max_ratio must be in [0, 1)");
  if (!(max_difference >= 0.0))
    throw std::invalid_argument("repeated frames: max_difference must be >= 0");
}

std::vector<int> FindRepeatedFrames(const std::vector<cv::Mat>& gray, int reference,
                                    const RepeatedFramesOptions& options) {
  options.Check();
  const int n = static_cast<int>(gray.size());
  std::vector<int> repeats(n, -1);
  if (n < 3) return repeats;
  // difference[i]: between frames i and i + 1.
  std::vector<double> difference(n - 1);
  cv::Mat absolute;
  for (int i = 0; i + 1 < n; ++i) {
    cv::absdiff(gray[i], gray[i + 1], absolute);
    difference[i] = cv::mean(absolute)[0];
  }
  std::vector<double> sorted = difference;
  const auto upper = sorted.begin() + (3 * (n - 1)) / 4;
  std::nth_element(sorted.begin(), upper, sorted.end());
  const double bound = std::min(options.max_ratio * *upper, options.max_difference);
  // Runs of frames joined by repeats; each run's representative is its first
  // frame, or the reference where the run holds it.
  int run_start = 0;
  for (int i = 1; i <= n; ++i) {
    if (i < n && difference[i - 1] < bound) continue;
    const int keep = reference >= run_start && reference < i ? reference : run_start;
    for (int k = run_start; k < i; ++k)
      if (k != keep) repeats[k] = keep;
    run_start = i;
  }
  return repeats;
}

}  // namespace dfsm
