#include "core/sparse/rotation_init.h"

#include <gtest/gtest.h>

#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

TEST(EstimateRotations, FollowsTheContractConventionAndIsAccurate) {
  TrackSimulatorOptions options;
  options.k1 = options.k2 = 0.0;
  options.rotation_deg = 2.0;
  const TrackSimulation sim = SimulateTracks(options);
  {
    const auto rotations = EstimateRotations(sim.tracks, sim.camera);
    ASSERT_EQ(rotations.size(), sim.poses.size());
    EXPECT_TRUE(rotations[0].isIdentity());
    for (size_t i = 1; i < rotations.size(); ++i) {
      // A rotation-only fit absorbs part of the translation's parallax: its
      // error is bounded by the angle the baseline subtends at the nearest depth.
      const double bias_bound_deg = sim.poses[i].Centre().norm() / options.min_depth * 180.0 / M_PI;
      EXPECT_LT(RotationErrorDeg(rotations[i], sim.poses[i].R), bias_bound_deg) << "frame " << i;
      EXPECT_GT(RotationErrorDeg(rotations[i].transpose(), sim.poses[i].R), 0.2) << "frame " << i;
    }
  }
}

TEST(EstimateRotations, IsExactForPureRotation) {
  TrackSimulatorOptions options;
  options.baseline = 0.0;
  options.rotation_deg = 1.5;
  const TrackSimulation sim = SimulateTracks(options);
  const auto rotations = EstimateRotations(sim.tracks, sim.camera);
  for (size_t i = 1; i < rotations.size(); ++i)
    EXPECT_LT(RotationErrorDeg(rotations[i], sim.poses[i].R), 1e-6);
}

}  // namespace
}  // namespace dfsm
