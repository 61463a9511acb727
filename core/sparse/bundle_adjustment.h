// Step 4 of the method: self-calibrating bundle adjustment (Ceres, Huber loss)
// refining f, k1, k2, every pose and every inverse depth.
#pragma once

#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"
#include "core/camera/rolling_shutter.h"
#include "core/io/result.h"
#include "core/sparse/calibration_uncertainty.h"
#include "core/sparse/feature_tracks.h"

namespace dfsm {

struct BundleAdjustmentOptions {
  int max_iterations = 100;
  double huber_px = 1.0;
  // Ceres' relative cost decrease under which it declares CONVERGENCE.
  double function_tolerance = 1e-6;
  int num_threads = 1;
  // Radial terms refined: 2 (k1, k2), 1 (k1; k2 held at the state's value)
  // or 0 (both held). A lens the dense stage cannot invert is refitted with
  // fewer terms (sparse_reconstruction.h).
  int distortion_terms = 2;
  // The weak intrinsics prior (intrinsics_prior.h): sigma of log(f / max(w, h))
  // and of the distortion's shift of the image corner, as a fraction of the
  // corner's distance from the centre. 0 disables the prior.
  double log_f_prior_sigma = 0.5;
  double corner_shift_prior_sigma = 0.1;
  // A lens prior: k1 and k2 each zero-mean with this sigma (0: off). Measured
  // on and off over the calibration sweep (docs/experiments/106-priors-sweep.md).
  double lens_k_prior_sigma = 0.0;
  // Holds f, k1, k2 at the state's values (a known calibration).
  bool fix_intrinsics = false;
  // Holds every inverse depth at the state's values: the poses (and readout,
  // velocities) that best explain the tracks at depths given from elsewhere,
  // e.g. a depth sensor's (bench/pinned_depth.h). The depths are then no
  // parameters, so no covariance is computed with it.
  bool hold_inverse_depths = false;
  // Estimates the rolling shutter's readout (SparseState::readout is its
  // start), in [-kMaxReadout, kMaxReadout]; otherwise the state's readout is
  // held. Not bounded at 0: a global shutter's readout then converges like
  // any parameter (at a bound of 0, Ceres took 38 iterations instead of 5 on
  // the flower clip and stopped at a higher cost), and a negative one is a
  // sensor read bottom-up.
  bool estimate_readout = false;
  // With a rolling shutter, each frame's angular velocity is a parameter
  // (core/sparse/angular_velocity_reprojection_error.h), tied to its
  // neighbours' rotation step with this sigma in pixels at f per frame
  // interval; 0: the rows turn along the line between frame poses.
  double angular_velocity_sigma_px = 0.0;
  // A known calibration as a prior: the state's initial camera is its centre,
  // with these widths (f 0: no prior). The distortion width is in pixels of
  // the shift of two radii (half-way and the corner), like IntrinsicsPrior;
  // 0 leaves the distortion free (only f is known, e.g. from EXIF).
  double known_f_sigma_percent = 0.0;
  double known_distortion_sigma_px = 0.0;
  bool HasKnownIntrinsicsPrior() const { return known_f_sigma_percent > 0.0; }
  // The covariance of the intrinsics counts tracking noise only, and the
  // errors of real tracks are not white (interpolation and JPEG biases,
  // corners on depth edges, local minima): the noise is taken as this many
  // times what the residuals show. Measured over the calibration sweep
  // (docs/experiments/104-calibration-sweep.md).
  double uncertainty_inflation = 2.8;
  // ... and for a wide lens (the estimated f below wide_angle_focal_ratio x
  // the longer image side) by a further (wide_angle_focal_ratio x side /
  // f)^wide_angle_inflation_exponent. At 64-85 deg the lens terms the model
  // lacks and the f-k1 coupling bias f long, and with the inflation above
  // the sigmas covered the truth within 2 sigma on 62-73 % of the wide
  // sweep's bursts instead of 90 %. The ratio sits above the normal sweep's
  // 0.8 because the biased estimate of a wide lens reads up to 10-30 % long.
  // Chosen on the wide sweep's seeds 1 and 2 (f 93 %, distortion 90 % within
  // 2 sigma), checked on seed 3 (docs/experiments/108-wide-lens-sigma.md). Only
  // where f is estimated without a known prior: the bias is
  // the estimate's. 0: no further inflation.
  double wide_angle_focal_ratio = 0.9;
  double wide_angle_inflation_exponent = 4.0;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

// The wide-angle factor above for `camera` (1 where it does not apply), and
// the noise inflation the covariance of its adjustment takes:
// uncertainty_inflation times that factor.
double WideAngleFactor(const BundleAdjustmentOptions& options, const CameraModel& camera);
double UncertaintyInflation(const BundleAdjustmentOptions& options, const CameraModel& camera);

// The state the adjustment refines; the principal point stays at its value.
struct SparseState {
  CameraModel camera;
  std::vector<Pose> poses;             // per frame; the reference stays R = I, T = 0
  std::vector<double> inverse_depths;  // per track
  // The rolling shutter's readout the poses are for, in frame intervals
  // (core/camera/rolling_shutter.h); 0 is a global shutter. With a readout,
  // the burst's frames must be in capture order.
  double readout = 0.0;
  // Each frame's capture time in frame intervals, increasing (io/frame_times.h:
  // a dropped frame leaves a gap of 2); empty: consecutive frames. Only the
  // rolling shutter's path between frames reads it.
  std::vector<double> frame_times;
  // Each frame's angular velocity where the adjustment estimated them
  // (BundleAdjustmentOptions::angular_velocity_sigma_px); empty otherwise.
  AngularVelocities angular_velocities;
};

// Refines `state` in place over the tracks whose `use` flag is set. Returns the
// summary that result.json reports (init is left for the caller to fill in).
// With `uncertainty`, also the marginal covariance of the intrinsics at the
// solution (calibration_uncertainty.h); it costs one jacobian evaluation.
BundleAdjustmentSummary RunBundleAdjustment(const FeatureTracks& tracks,
                                            const std::vector<bool>& use, SparseState* state,
                                            const BundleAdjustmentOptions& options = {},
                                            CalibrationUncertainty* uncertainty = nullptr);

// Per-track RMS reprojection error (pixels, undistorted domain) of `state`.
std::vector<double> TrackReprojectionErrors(const FeatureTracks& tracks, const SparseState& state);

// The residual of every observation at `state` (pixels of f, undistorted
// domain: f times the projection less the undistorted observation), frame by
// frame: residuals[i].col(j); zero in the reference.
std::vector<Eigen::Matrix2Xd> ObservationResiduals(const FeatureTracks& tracks,
                                                   const SparseState& state);

// The same with each track's inverse depth at its own least-squares best
// under the state's camera and poses (the state is not changed): how well
// the geometry explains every track, whether the adjustment used it or not.
// Those depths go to `best_inverse_depths` where given.
std::vector<double> TrackReprojectionErrorsAtBestDepth(
    const FeatureTracks& tracks, const SparseState& state,
    std::vector<double>* best_inverse_depths = nullptr);

}  // namespace dfsm
