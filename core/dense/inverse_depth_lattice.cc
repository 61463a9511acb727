#include "core/dense/inverse_depth_lattice.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace dfsm {

InverseDepthLattice InverseDepthLattice::FromSparse(
    const std::vector<double>& sparse_inverse_depths, double margin, int planes) {
  if (planes < 2)
    throw std::invalid_argument("dense: need at least 2 planes, got " + std::to_string(planes));
  if (!(margin >= 0.0) || !std::isfinite(margin))
    throw std::invalid_argument("dense: inverse-depth margin must be >= 0, got " +
                                std::to_string(margin));
  if (sparse_inverse_depths.empty())
    throw std::invalid_argument("dense: no sparse inverse depths to choose the swept range from");
  double lo = sparse_inverse_depths.front(), hi = lo;
  for (size_t j = 0; j < sparse_inverse_depths.size(); ++j) {
    const double w = sparse_inverse_depths[j];
    if (!std::isfinite(w) || w <= 0.0)
      throw std::invalid_argument("dense: sparse inverse depth " + std::to_string(j) + " is " +
                                  std::to_string(w) + " (must be finite and positive)");
    lo = std::min(lo, w);
    hi = std::max(hi, w);
  }
  // A single depth (or a fronto-parallel scene) still gets a range to search.
  const double width = std::max(hi - lo, 0.05 * hi);
  InverseDepthLattice lattice;
  // Never reach w <= 0: at most halve the nearest-to-infinity sparse inverse depth.
  lattice.min_inverse_depth = std::max(lo - margin * width, 0.5 * lo);
  lattice.max_inverse_depth = hi + margin * width;
  lattice.planes = planes;
  return lattice;
}

}  // namespace dfsm
