// The scale of residual magnitudes that ignores outliers.
#pragma once

#include <algorithm>
#include <vector>

namespace dfsm {

// 1.4826 x the median of `magnitudes` (|residual| >= 0): the standard deviation
// of Gaussian residuals, estimated from their median absolute value, so up to
// half of them may be outliers. 0 for none.
inline double RobustSigma(std::vector<double> magnitudes) {
  if (magnitudes.empty()) return 0.0;
  const auto middle = magnitudes.begin() + magnitudes.size() / 2;
  std::nth_element(magnitudes.begin(), middle, magnitudes.end());
  return 1.4826 * *middle;
}

}  // namespace dfsm
