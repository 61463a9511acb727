#include "core/dense/inverse_depth_lattice.h"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

namespace dfsm {
namespace {

TEST(InverseDepthLatticeTest, WidensTheSparseRangeByTheMargin) {
  const InverseDepthLattice lattice = InverseDepthLattice::FromSparse({1.0, 1.5, 2.0}, 0.2, 128);
  EXPECT_DOUBLE_EQ(lattice.max_inverse_depth, 2.0 + 0.2 * 1.0);
  EXPECT_DOUBLE_EQ(lattice.min_inverse_depth, 1.0 - 0.2 * 1.0);
  EXPECT_EQ(lattice.planes, 128);
  EXPECT_DOUBLE_EQ(lattice.At(0), lattice.min_inverse_depth);
  EXPECT_NEAR(lattice.At(127), lattice.max_inverse_depth, 1e-12);
}

TEST(InverseDepthLatticeTest, NeverReachesInfinityOrAnEmptyRange) {
  // A margin past w = 0 stops at half the smallest sparse inverse depth.
  const InverseDepthLattice wide = InverseDepthLattice::FromSparse({0.1, 2.0}, 0.5, 64);
  EXPECT_DOUBLE_EQ(wide.min_inverse_depth, 0.05);
  // One depth only still gets a range around it.
  const InverseDepthLattice single = InverseDepthLattice::FromSparse({1.0, 1.0}, 0.2, 64);
  EXPECT_LT(single.min_inverse_depth, 1.0);
  EXPECT_GT(single.max_inverse_depth, 1.0);
}

TEST(InverseDepthLatticeTest, RejectsBadInputsByName) {
  EXPECT_THROW(InverseDepthLattice::FromSparse({}, 0.2, 128), std::invalid_argument);
  EXPECT_THROW(InverseDepthLattice::FromSparse({1.0}, 0.2, 1), std::invalid_argument);
  EXPECT_THROW(InverseDepthLattice::FromSparse({1.0}, -0.1, 128), std::invalid_argument);
  try {
    InverseDepthLattice::FromSparse({1.0, -2.0}, 0.2, 128);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sparse inverse depth 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(
      InverseDepthLattice::FromSparse({1.0, std::numeric_limits<double>::quiet_NaN()}, 0.2, 128),
      std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
