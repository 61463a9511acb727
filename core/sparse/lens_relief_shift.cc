#include "core/sparse/lens_relief_shift.h"

#include <algorithm>
#include <cmath>

namespace dfsm {

double LensReliefShift(const FeatureTracks& tracks, const std::vector<bool>& use,
                       const SparseState& state, BundleAdjustmentOptions options) {
  SparseState k1_alone = state;
  k1_alone.camera.k2 = 0.0;
  options.distortion_terms = 1;
  RunBundleAdjustment(tracks, use, &k1_alone, options);
  // Least squares w' = a w + b over the inlier tracks.
  double n = 0.0, sw = 0.0, sv = 0.0, sww = 0.0, swv = 0.0;
  for (size_t j = 0; j < use.size(); ++j) {
    if (!use[j]) continue;
    const double w = state.inverse_depths[j], v = k1_alone.inverse_depths[j];
    n += 1.0, sw += w, sv += v, sww += w * w, swv += w * v;
  }
  const double determinant = n * sww - sw * sw;
  if (!(n >= 2.0) || !(determinant > 0.0)) return -1.0;
  const double a = (n * swv - sw * sv) / determinant, b = (sv - a * sw) / n;
  if (!(a > 0.0) || !std::isfinite(b)) return -1.0;
  std::vector<double> shifts;
  for (size_t j = 0; j < use.size(); ++j)
    if (use[j] && state.inverse_depths[j] > 0.0)
      shifts.push_back(std::abs(b / (a * state.inverse_depths[j])));
  if (shifts.empty()) return -1.0;
  std::nth_element(shifts.begin(), shifts.begin() + shifts.size() / 2, shifts.end());
  return shifts[shifts.size() / 2];
}

}  // namespace dfsm
