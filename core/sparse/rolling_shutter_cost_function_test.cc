#include "core/sparse/rolling_shutter_cost_function.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "tests/support/jacobian_check.h"

namespace dfsm {
namespace {

using Shared = RollingShutterCostFunction::ReferenceNeighbour;

// One residual's parameters, drawn around a small-motion burst's: a 1080p
// camera with distortion of either sign, poses of a few milliradians and
// centimetres, and readouts from none to a phone's (0.6) and read bottom-up.
struct Parameters {
  double intrinsics[3];
  double pose[6], neighbour[6], reference_neighbour[6];
  double inverse_depth[1], readout[1];
};

Parameters DrawParameters(std::mt19937* rng, double readout) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Parameters q;
  q.intrinsics[0] = 1500.0 + 300.0 * unit(*rng);
  q.intrinsics[1] = 0.1 * unit(*rng);
  q.intrinsics[2] = 0.05 * unit(*rng);
  for (double* pose : {q.pose, q.neighbour, q.reference_neighbour})
    for (int k = 0; k < 6; ++k) pose[k] = (k < 3 ? 0.02 : 0.01) * unit(*rng);
  q.inverse_depth[0] = 0.2 + 0.15 * unit(*rng);
  q.readout[0] = readout;
  return q;
}

std::vector<double*> Blocks(Parameters* q, Shared shared) {
  std::vector<double*> blocks = {q->intrinsics, q->pose, q->neighbour};
  if (shared == Shared::kOwnBlock) blocks.push_back(q->reference_neighbour);
  blocks.push_back(q->inverse_depth);
  blocks.push_back(q->readout);
  return blocks;
}

// The residual and every Jacobian block of the hand-written cost function
// equal autodiff's of RollingShutterReprojectionError::Evaluate, for each way
// the reference neighbour's block is shared, each readout and both sides (a
// rate of 1/2: a dropped frame between the frame and its neighbour).
TEST(RollingShutterCostFunction, MatchesTheAutodiffOfTheResidual) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> column(0.0, 1919.0), row(0.0, 1079.0);
  int compared = 0;
  for (const Shared shared : {Shared::kOwnBlock, Shared::kFrame, Shared::kFrameNeighbour})
    for (const double readout : {0.0, 0.3, 0.6, -0.5})
      for (const double reference_rate : {1.0, -1.0, 0.5})
        for (int draw = 0; draw < 10; ++draw) {
          const RollingShutterReprojectionError error({column(rng), row(rng)},
                                                      {column(rng), row(rng)}, 960.0, 540.0, 1080,
                                                      reference_rate, draw % 2 ? 1.0 : -0.5);
          Parameters q = DrawParameters(&rng, readout);
          const std::vector<double*> blocks = Blocks(&q, shared);
          const RollingShutterCostFunction analytic(error, shared);
          const std::unique_ptr<ceres::CostFunction> autodiff(
              RollingShutterReprojectionError::CreateAutoDiff(error, shared));
          ExpectSameResidualAndJacobians(analytic, *autodiff, blocks.data(),
                                         "readout " + std::to_string(readout));
          ++compared;
        }
  EXPECT_EQ(compared, 3 * 4 * 3 * 10);
}

// Ceres passes no Jacobian for a block held constant (the reference's pose,
// a known readout, fixed intrinsics); the others are still written.
TEST(RollingShutterCostFunction, SkipsTheJacobiansOfConstantBlocks) {
  std::mt19937 rng(3);
  const RollingShutterReprojectionError error({300.0, 200.0}, {310.0, 205.0}, 960.0, 540.0, 1080,
                                              1.0, -1.0);
  Parameters q = DrawParameters(&rng, 0.6);
  const std::vector<double*> blocks = Blocks(&q, Shared::kOwnBlock);
  const RollingShutterCostFunction analytic(error, Shared::kOwnBlock);
  double pose_jacobian[12] = {};
  double* jacobians[6] = {nullptr, pose_jacobian, nullptr, nullptr, nullptr, nullptr};
  double residuals[2];
  ASSERT_TRUE(analytic.Evaluate(blocks.data(), residuals, jacobians));
  double sum = 0.0;
  for (const double d : pose_jacobian) sum += std::abs(d);
  EXPECT_GT(sum, 0.0);
}

}  // namespace
}  // namespace dfsm
