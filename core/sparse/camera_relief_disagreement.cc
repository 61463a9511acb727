#include "core/sparse/camera_relief_disagreement.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace dfsm {
namespace {

double Median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace

double CameraReliefDisagreement(const std::vector<double>& inverse_depths_a,
                                const std::vector<bool>& use_a,
                                const std::vector<double>& inverse_depths_b,
                                const std::vector<bool>& use_b) {
  const size_t m = inverse_depths_a.size();
  if (use_a.size() != m || inverse_depths_b.size() != m || use_b.size() != m)
    throw std::invalid_argument("CameraReliefDisagreement: the solutions hold different tracks");
  std::vector<double> ratios;
  for (size_t j = 0; j < m; ++j)
    if (use_a[j] && use_b[j] && inverse_depths_a[j] != 0.0 &&
        inverse_depths_b[j] / inverse_depths_a[j] > 0.0)
      ratios.push_back(inverse_depths_b[j] / inverse_depths_a[j]);
  if (ratios.size() < 2) return -1.0;
  const double scale = Median(ratios);
  for (double& ratio : ratios) ratio = std::abs(ratio / scale - 1.0);
  return Median(ratios);
}

}  // namespace dfsm
