// The swept planes: fronto-parallel in the reference camera, uniform in
// inverse depth (uniform in parallax, which is what photo-consistency sees).
#pragma once

#include <vector>

namespace dfsm {

struct InverseDepthLattice {
  double min_inverse_depth = 0.0;
  double max_inverse_depth = 0.0;
  int planes = 0;

  double step() const { return (max_inverse_depth - min_inverse_depth) / (planes - 1); }
  // Inverse depth of a (possibly fractional) plane index.
  double At(double plane) const { return min_inverse_depth + plane * step(); }

  // The range of the sparse inverse depths widened by `margin` times its width
  // on both sides, kept strictly positive (a plane at infinity has no depth).
  // Throws std::invalid_argument naming the problem: fewer than 2 planes, no
  // sparse inverse depth, a non-finite or non-positive one.
  static InverseDepthLattice FromSparse(const std::vector<double>& sparse_inverse_depths,
                                        double margin, int planes);
};

}  // namespace dfsm
