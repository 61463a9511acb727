// The self-calibrating adjustment's bias from the tracks' own noise, measured
// by a parametric bootstrap (Efron & Tibshirani 1993, ch. 10).
//
// In a small-motion burst f shows only through second-order terms of the
// rotational flow, so its likelihood is flat and skewed: noise on the tracks
// biases f long and k1 down, growing as the square of the noise over the
// flow's second-order signal, and about as much with 10 frames as with 30
// (each frame brings six pose parameters of its own); the weak intrinsics
// prior pulls the other way, towards max(w, h) (docs/experiments/132-noise-bias.md,
// for the measurements).
//
// The bootstrap measures the sum where the solution stands: replica tracks
// that the solution explains exactly, plus Gaussian noise as large as its
// residuals show, are adjusted from the solution again; the replicas' mean
// f, k1, k2 (and readout) less the solution's is the bias. The noise goes on
// the frames' observations, all of it, in captured pixels: the model the
// sweeps were measured with. (The covariance, calibration_uncertainty.h,
// gives part of the residual to the reference pixel; a bootstrap that does
// the same was not measured.) A fusion of bursts
// takes it off each burst's camera (SparseReconstruction::DebiasedCamera):
// there the bursts' noise averages out and their bias would not. A burst's
// own depth keeps the camera that fits its tracks best: with the bias taken
// off and the poses refitted under it, TUM fr1/xyz's self-calibrated depth
// was worse (docs/experiments/132-noise-bias.md).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/feature_tracks.h"

namespace dfsm {

struct BootstrapBiasOptions {
  // Replica adjustments (0: no correction), in antithetic pairs: the second
  // of a pair takes the first one's noise negated, so the estimate's part
  // linear in the noise cancels within the pair and the mean keeps the
  // second-order shift, the bias, with little noise of its own. Four such
  // replicas came closer to 64 independent ones than eight independent did
  // (docs/experiments/010-antithetic-bias-replicas.md). Even.
  int replicas = 4;
  uint64_t seed = 1;  // of the replicas' noise: the result is deterministic
  // Only where the camera is uncertain enough for the bias to matter: the
  // bias grows as the square of the relative sigma_f that the tracks' noise
  // alone gives (before the uncertainty's inflation and wide-angle factor),
  // while the replicas' mean carries a noise of about a third of it. It
  // keeps the replicas off bursts that observe f well (the ideal 1080p
  // benchmark burst); the sweeps' medians were measured with it.
  double min_sigma_f_percent = 0.35;
  // A bias of f beyond this share of f is not taken off (usable false): a
  // valley, not a bias. The sweeps' largest was 15 % (a wide lens at 320x240,
  // its f 24 % long and 5 % after); against sigma_f it cannot be bounded: the
  // corrections that were right reached 4-8 sigma_f before the inflation.
  double max_correction_percent = 25.0;

  // Throws std::invalid_argument naming the option out of its range.
  void Check() const;
};

// The intrinsics' bias: the replicas' mean estimate less the solution's.
struct IntrinsicsBias {
  double f = 0.0, k1 = 0.0, k2 = 0.0, readout = 0.0;
  double noise_px = 0.0;  // the replicas' tracking noise, per coordinate
  int replicas = 0;       // counted: both replicas of a pair adjusted
  // Set by MeasureBiasIfItMatters: the sigma_f the tracks' noise alone gives
  // the solution (before the uncertainty's inflation).
  double sigma_f_noise_px = 0.0;
  // Whether the bias can be taken off: at least half the replicas counted,
  // and within BootstrapBiasOptions::max_correction_percent of f.
  bool usable = false;
};

// Whether the bias is worth measuring where the tracks' noise alone gives
// the camera of focal length `f` a sigma of `sigma_f_noise_px`
// (BootstrapBiasOptions::min_sigma_f_percent).
bool BiasMatters(double sigma_f_noise_px, double f, const BootstrapBiasOptions& bootstrap);

// One replica's adjusted camera and readout; `solved` false where its
// adjustment failed.
struct ReplicaEstimate {
  CameraModel camera;
  double readout = 0.0;
  bool solved = false;
};

// The mean camera and readout less the solution's over the antithetic pairs
// (ReplicaTracks) whose two replicas both solved, with `replicas` and
// `usable` set; a pair with one failed replica is left out whole, as its
// partner's shift linear in the noise would no longer cancel. A replica that
// ran out of iterations counts:
// leaving out the slow ones would draw the mean towards the quick, small
// shifts.
IntrinsicsBias MeanShift(const std::vector<ReplicaEstimate>& replicas, const CameraModel& camera,
                         double readout, const BootstrapBiasOptions& bootstrap);

// The tracks `state` explains exactly: every used track moved onto the
// state's projection in every frame; the others as observed.
FeatureTracks ExplainedTracks(const FeatureTracks& tracks, const std::vector<bool>& use,
                              const SparseState& state);

// Replica `replica` of a bootstrap seeded `seed`: `explained`
// (ExplainedTracks) plus Gaussian noise of `noise_px` on each coordinate of
// every used track in every frame but the reference. Replicas 2k and 2k + 1
// are an antithetic pair: the same draw, the second negated.
FeatureTracks ReplicaTracks(const FeatureTracks& explained, const std::vector<bool>& use,
                            double noise_px, uint64_t seed, int replica);

// The noise of the used tracks per coordinate, from their reprojection
// errors at `state`, corrected for the parameters the adjustment `options`
// fitted.
double ResidualNoisePx(const FeatureTracks& tracks, const std::vector<bool>& use,
                       const SparseState& state, const BundleAdjustmentOptions& options);

// Measures the bias of the adjustment `options` at its solution `state`;
// std::invalid_argument where `options` hold the intrinsics or give them a
// known prior (the bias is the self-calibration's). The replicas run in parallel on
// OpenCV's pool, each single-threaded; the result does not depend on the
// thread count.
IntrinsicsBias EstimateIntrinsicsBias(const FeatureTracks& tracks, const std::vector<bool>& use,
                                      const SparseState& state,
                                      const BundleAdjustmentOptions& options,
                                      const BootstrapBiasOptions& bootstrap);

// EstimateIntrinsicsBias where it matters: where the relative sigma_f of
// `state` before the uncertainty's inflation (one covariance evaluation)
// reaches bootstrap.min_sigma_f_percent; with sigma_f_noise_px and usable set.
// Empty below that, or where the covariance is not available.
std::optional<IntrinsicsBias> MeasureBiasIfItMatters(const FeatureTracks& tracks,
                                                     const std::vector<bool>& use,
                                                     const SparseState& state,
                                                     const BundleAdjustmentOptions& options,
                                                     const BootstrapBiasOptions& bootstrap);

// `camera` less the bias of its f, k1, k2 where `bias` is usable; `camera`
// as it is otherwise.
CameraModel Debiased(const CameraModel& camera, const std::optional<IntrinsicsBias>& bias);

}  // namespace dfsm
