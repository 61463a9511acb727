#include "core/sparse/angular_velocity_reprojection_error.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/sparse/angular_velocity_cost_function.h"
#include "tests/support/jacobian_check.h"

namespace dfsm {
namespace {

using VelocityShared = AngularVelocityReprojectionError::ReferenceNeighbour;

// One residual's parameters around a small-motion burst's (1080p).
struct VelocityParameters {
  double intrinsics[3];
  double pose[6], neighbour[6], reference_neighbour[6];
  double velocity[3], reference_velocity[3];
  double inverse_depth[1], readout[1];
};

VelocityParameters DrawVelocityParameters(std::mt19937* rng, double readout) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  VelocityParameters q;
  q.intrinsics[0] = 1500.0 + 300.0 * unit(*rng);
  q.intrinsics[1] = 0.1 * unit(*rng);
  q.intrinsics[2] = 0.05 * unit(*rng);
  for (double* pose : {q.pose, q.neighbour, q.reference_neighbour})
    for (int k = 0; k < 6; ++k) pose[k] = (k < 3 ? 0.02 : 0.01) * unit(*rng);
  q.inverse_depth[0] = 0.2 + 0.15 * unit(*rng);
  q.readout[0] = readout;
  return q;
}

std::vector<const double*> VelocityBlocks(const VelocityParameters& q, VelocityShared shared) {
  std::vector<const double*> blocks = {q.intrinsics, q.pose, q.neighbour};
  if (shared == VelocityShared::kOwnBlock) blocks.push_back(q.reference_neighbour);
  for (const double* block : {q.velocity, q.reference_velocity, q.inverse_depth, q.readout})
    blocks.push_back(block);
  return blocks;
}

// Where each velocity is its neighbour's rotation step, the rows turn along
// the line between frame poses: the residual is RollingShutterReprojection
// Error's, through the cost function the adjustment runs (its blocks in order, for
// each way the reference neighbour's block is shared). A velocity off the
// step moves the residual.
TEST(AngularVelocityReprojectionError, IsTheLinesResidualAtTheLinesVelocities) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> column(0.0, 1919.0), row(0.0, 1079.0);
  for (const VelocityShared shared :
       {VelocityShared::kOwnBlock, VelocityShared::kFrame, VelocityShared::kFrameNeighbour})
    for (const double readout : {0.3, 0.6, -0.5})
      for (const double reference_rate : {1.0, -1.0, 0.5})
        for (int draw = 0; draw < 5; ++draw) {
          const Eigen::Vector2d reference(column(rng), row(rng)), observed(column(rng), row(rng));
          const double frame_rate = draw % 2 ? 1.0 : -0.5;
          VelocityParameters q = DrawVelocityParameters(&rng, readout);
          const double* m = shared == VelocityShared::kFrame            ? q.pose
                            : shared == VelocityShared::kFrameNeighbour ? q.neighbour
                                                                        : q.reference_neighbour;
          for (int k = 0; k < 3; ++k) {
            q.velocity[k] = frame_rate * (q.neighbour[k] - q.pose[k]);
            q.reference_velocity[k] = reference_rate * m[k];
          }
          double line[2];
          RollingShutterReprojectionError(reference, observed, 960.0, 540.0, 1080, reference_rate,
                                          frame_rate)
              .Evaluate(q.intrinsics, q.pose, q.neighbour, m, q.inverse_depth, q.readout, line);
          const auto cost = std::make_unique<AngularVelocityCostFunction>(
              AngularVelocityReprojectionError(reference, observed, 960.0, 540.0, 1080,
                                               reference_rate, frame_rate),
              shared);
          const std::vector<const double*> blocks = VelocityBlocks(q, shared);
          double residual[2];
          ASSERT_TRUE(cost->Evaluate(blocks.data(), residual, nullptr));
          EXPECT_NEAR(residual[0], line[0], 1e-9);
          EXPECT_NEAR(residual[1], line[1], 1e-9);
          q.velocity[0] += 0.002;  // 3 px at f per frame interval
          ASSERT_TRUE(cost->Evaluate(blocks.data(), residual, nullptr));
          if (std::abs(RowTime(readout, observed.y(), 1080)) > 0.05) {
            EXPECT_GT(std::hypot(residual[0] - line[0], residual[1] - line[1]), 0.05);
          }
        }
}

// The residual and every Jacobian block of the hand-written cost function
// equal autodiff's of AngularVelocityReprojectionError::Evaluate, for each
// way the reference neighbour's block is shared, each readout (none, a
// phone's, read bottom-up), both sides and a dropped frame's rate of 1/2,
// with velocities off the line's.
TEST(AngularVelocityCostFunction, MatchesTheAutodiffOfTheResidual) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> column(0.0, 1919.0), row(0.0, 1079.0), unit(-1.0, 1.0);
  int compared = 0;
  for (const VelocityShared shared :
       {VelocityShared::kOwnBlock, VelocityShared::kFrame, VelocityShared::kFrameNeighbour})
    for (const double readout : {0.0, 0.3, 0.6, -0.5})
      for (const double reference_rate : {1.0, -1.0, 0.5})
        for (int draw = 0; draw < 10; ++draw) {
          const AngularVelocityReprojectionError error({column(rng), row(rng)},
                                                       {column(rng), row(rng)}, 960.0, 540.0, 1080,
                                                       reference_rate, draw % 2 ? 1.0 : -0.5);
          VelocityParameters q = DrawVelocityParameters(&rng, readout);
          for (int k = 0; k < 3; ++k) {
            q.velocity[k] = 0.02 * unit(rng);
            q.reference_velocity[k] = 0.02 * unit(rng);
          }
          const std::vector<const double*> blocks = VelocityBlocks(q, shared);
          const AngularVelocityCostFunction analytic(error, shared);
          const std::unique_ptr<ceres::CostFunction> autodiff(
              AngularVelocityReprojectionError::CreateAutoDiff(error, shared));
          ExpectSameResidualAndJacobians(analytic, *autodiff, blocks.data(),
                                         "readout " + std::to_string(readout));
          ++compared;
        }
  EXPECT_EQ(compared, 3 * 4 * 3 * 10);
}

// Ceres passes no Jacobian for a block held constant (the reference's
// velocity and pose, a known readout, fixed intrinsics); the others are still
// written.
TEST(AngularVelocityCostFunction, SkipsTheJacobiansOfConstantBlocks) {
  std::mt19937 rng(3);
  const AngularVelocityReprojectionError error({300.0, 200.0}, {310.0, 205.0}, 960.0, 540.0, 1080,
                                               1.0, -1.0);
  VelocityParameters q = DrawVelocityParameters(&rng, 0.6);
  for (int k = 0; k < 3; ++k) q.velocity[k] = q.reference_velocity[k] = 0.01;
  const std::vector<const double*> blocks = VelocityBlocks(q, VelocityShared::kOwnBlock);
  const AngularVelocityCostFunction analytic(error, VelocityShared::kOwnBlock);
  double velocity_jacobian[6] = {};
  double* jacobians[8] = {nullptr,           nullptr, nullptr, nullptr,
                          velocity_jacobian, nullptr, nullptr, nullptr};
  double residuals[2];
  ASSERT_TRUE(analytic.Evaluate(blocks.data(), residuals, jacobians));
  double sum = 0.0;
  for (const double d : velocity_jacobian) sum += std::abs(d);
  EXPECT_GT(sum, 0.0);
}

// The prior is zero at the neighbours' rotation step, f / sigma per radian
// off it, with a neighbour that is the reference (no block) at rotation 0.
TEST(AngularVelocityPrior, MeasuresTheVelocityAgainstTheNeighboursStep) {
  const double after[6] = {0.004, -0.002, 0.001, 0.01, 0.0, 0.0};
  const double before[6] = {0.001, 0.001, 0.0, 0.0, 0.0, 0.0};
  double velocity[3] = {0.0015, -0.0015, 0.0005};  // (after - before) / 2
  const std::unique_ptr<ceres::CostFunction> both(
      AngularVelocityPrior::Create(1000.0 / 2.0, 0.5, true, true));
  const double* blocks[] = {velocity, after, before};
  double residual[3];
  ASSERT_TRUE(both->Evaluate(blocks, residual, nullptr));
  for (double r : residual) EXPECT_NEAR(r, 0.0, 1e-12);
  velocity[0] += 0.002;  // 2 px at f = 1000: one sigma of 2 px
  ASSERT_TRUE(both->Evaluate(blocks, residual, nullptr));
  EXPECT_NEAR(residual[0], 1.0, 1e-12);
  const std::unique_ptr<ceres::CostFunction> reference_before(
      AngularVelocityPrior::Create(500.0, 1.0, true, false));
  double next[3] = {0.004, -0.002, 0.001};
  const double* one[] = {next, after};
  ASSERT_TRUE(reference_before->Evaluate(one, residual, nullptr));
  for (double r : residual) EXPECT_NEAR(r, 0.0, 1e-12);
}

}  // namespace
}  // namespace dfsm
