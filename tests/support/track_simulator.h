// Noise-controlled feature tracks of a known small-motion scene, projected
// through the contract's camera model. Used by the sparse stage's tests and
// benchmarks, where images would only add KLT noise to what is measured.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"
#include "core/sparse/feature_tracks.h"

namespace dfsm {

struct TrackSimulation {
  CameraModel camera;
  std::vector<Pose> poses;             // per frame; reference is identity
  std::vector<double> inverse_depths;  // per track, true scale
  FeatureTracks tracks;                // distorted pixels, with noise
};

struct TrackSimulatorOptions {
  int width = 1920, height = 1080;
  int frames = 10;
  int tracks = 300;
  double f = 2100.0, k1 = -0.06, k2 = 0.015;
  double baseline = 0.008;    // extent of the camera path, metres
  double rotation_deg = 0.5;  // magnitude of the hand's rotation
  double min_depth = 0.7, max_depth = 3.0;
  double noise_px = 0.0;  // Gaussian pixel noise on every observation
  uint64_t seed = 1;
  // 0: the noise comes from the scene's random stream (seed); otherwise from a
  // stream of its own, so that one scene can be observed with many noise draws.
  uint64_t noise_seed = 0;
  // A rolling shutter's readout (core/camera/rolling_shutter.h): each
  // observation is taken at the pose of the row it lands on, and the inverse
  // depths are those of the reference row's camera. 0: a global shutter.
  double readout = 0.0;
  // With a readout: each frame's angular velocity, its rows turning at it
  // (core/camera/rolling_shutter.h); empty: along the line between frames.
  std::vector<Eigen::Vector3d> angular_velocities;
};

// Tracks sit on a grid over the reference image (as grided features do).
TrackSimulation SimulateTracks(const TrackSimulatorOptions& options);

}  // namespace dfsm
