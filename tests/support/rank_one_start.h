// The states the adjustment's tests share: simulated tracks initialized as
// the pipeline does (rotation-only rotations, then the rank-1
// factorization), and the simulation's own truth.
#pragma once

#include <gtest/gtest.h>

#include <vector>

#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/rank_one_init.h"
#include "core/sparse/rotation_init.h"
#include "tests/support/track_simulator.h"

namespace dfsm {

// The rank-1 start of `sim`'s tracks with `camera` (null: the generic
// initial guess, CameraModel::Initial); *use gets the start's inliers.
inline SparseState RankOneStart(const TrackSimulation& sim, std::vector<bool>* use,
                                const CameraModel* camera = nullptr) {
  SparseState state;
  state.camera = camera ? *camera : CameraModel::Initial(sim.camera.width, sim.camera.height);
  const RankOneResult init =
      RankOneInit(sim.tracks, state.camera, EstimateRotations(sim.tracks, state.camera));
  EXPECT_TRUE(init.ok);
  state.poses = init.poses;
  state.inverse_depths = init.inverse_depths;
  *use = init.inliers;
  return state;
}

// The simulation's own camera, poses and inverse depths, under `readout`.
inline SparseState SimulatedState(const TrackSimulation& sim, double readout = 0.0) {
  SparseState state;
  state.camera = sim.camera;
  state.poses = sim.poses;
  state.inverse_depths = sim.inverse_depths;
  state.readout = readout;
  return state;
}

}  // namespace dfsm
