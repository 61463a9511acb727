// The sparse tests' common case: tracks of a 640x480 phone camera with a
// rolling shutter, and the options that estimate its readout (so that the
// readout restarts run).
#pragma once

#include <cstdint>

#include "core/sparse/sparse_reconstruction.h"
#include "tests/support/track_simulator.h"

namespace dfsm {

// k1 -0.05, k2 0.01, 1 deg of tremor, 0.05 px of tracking noise, readout 0.6,
// at focal length `f`.
inline TrackSimulatorOptions RollingShutterPhone(double f, uint64_t seed) {
  TrackSimulatorOptions options;
  options.width = 640;
  options.height = 480;
  options.f = f;
  options.k1 = -0.05;
  options.k2 = 0.01;
  options.rotation_deg = 1.0;
  options.noise_px = 0.05;
  options.readout = 0.6;
  options.seed = seed;
  return options;
}

inline SparseOptions EstimatingTheReadout() {
  SparseOptions options;
  options.rolling_shutter.mode = RollingShutterOptions::Mode::kEstimate;
  return options;
}

}  // namespace dfsm
