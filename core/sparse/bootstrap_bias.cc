#include "core/sparse/bootstrap_bias.h"

#include <cmath>
#include <opencv2/core/utility.hpp>
#include <random>
#include <stdexcept>
#include <string>

namespace dfsm {

void BootstrapBiasOptions::Check() const {
  if (replicas < 0 || replicas > 64 || replicas % 2 != 0)
    throw std::invalid_argument(
        "bootstrap replicas must be an even number from 0 (off) to 64 (antithetic pairs), got " +
        std::to_string(replicas));
  if (!(min_sigma_f_percent >= 0.0))
    throw std::invalid_argument("bootstrap min_sigma_f_percent must be >= 0");
  if (!(max_correction_percent > 0.0))
    throw std::invalid_argument("bootstrap max_correction_percent must be > 0");
}

FeatureTracks ExplainedTracks(const FeatureTracks& tracks, const std::vector<bool>& use,
                              const SparseState& state) {
  const CameraModel& camera = state.camera;
  // Each observation moved onto the state's projection: the residual is f
  // (projection - undistorted observation). Under a rolling shutter the
  // projection depends on the observation's own row, so a second pass takes
  // what the first left (2e-4 px at a readout of 0.6) to 1e-8 px.
  FeatureTracks explained = tracks;
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<Eigen::Matrix2Xd> residuals = ObservationResiduals(explained, state);
    for (int i = 0; i < tracks.num_frames(); ++i) {
      if (i == tracks.reference) continue;
      for (int j = 0; j < tracks.num_tracks(); ++j) {
        if (!use[j]) continue;
        const Eigen::Vector2d projected =
            camera.PixelToUndistorted(explained.pixels[i].col(j)) + residuals[i].col(j) / camera.f;
        if (const std::optional<Eigen::Vector2d> pixel = camera.UndistortedToPixel(projected))
          explained.pixels[i].col(j) = *pixel;
      }
    }
  }
  return explained;
}

FeatureTracks ReplicaTracks(const FeatureTracks& explained, const std::vector<bool>& use,
                            double noise_px, uint64_t seed, int replica) {
  std::mt19937_64 rng(seed + 7919 * static_cast<uint64_t>(replica / 2));
  const double signed_noise_px = replica % 2 == 0 ? noise_px : -noise_px;
  std::normal_distribution<double> normal(0.0, 1.0);
  FeatureTracks noisy = explained;
  for (int i = 0; i < explained.num_frames(); ++i) {
    if (i == explained.reference) continue;
    for (int j = 0; j < explained.num_tracks(); ++j) {
      // Drawn for every observation, used or not, so that a track's noise
      // does not depend on which others are used.
      const Eigen::Vector2d noise(normal(rng), normal(rng));
      if (use[j]) noisy.pixels[i].col(j) += signed_noise_px * noise;
    }
  }
  return noisy;
}

double ResidualNoisePx(const FeatureTracks& tracks, const std::vector<bool>& use,
                       const SparseState& state, const BundleAdjustmentOptions& options) {
  const std::vector<Eigen::Matrix2Xd> residuals = ObservationResiduals(tracks, state);
  double sum = 0.0;
  int used = 0;
  for (int j = 0; j < tracks.num_tracks(); ++j) {
    if (!use[j]) continue;
    ++used;
    for (int i = 0; i < tracks.num_frames(); ++i) sum += residuals[i].col(j).squaredNorm();
  }
  const int frames = tracks.num_frames() - 1;
  const double observations = 2.0 * frames * used;
  // Poses, inverse depths less the scale's anchor, f and the radial terms
  // refined, and the readout where it is estimated.
  const int intrinsics = options.fix_intrinsics ? 0 : 1 + options.distortion_terms;
  const double parameters =
      6.0 * frames + (used - 1) + intrinsics + (options.estimate_readout ? 1 : 0);
  return observations > parameters ? std::sqrt(sum / (observations - parameters)) : 0.0;
}

namespace {

void RequireEstimatedIntrinsics(const BundleAdjustmentOptions& options, const char* caller) {
  if (options.fix_intrinsics || options.HasKnownIntrinsicsPrior())
    throw std::invalid_argument(std::string(caller) +
                                ": the intrinsics are held or given as a prior; the bias is the "
                                "self-calibration's");
}

}  // namespace

IntrinsicsBias EstimateIntrinsicsBias(const FeatureTracks& tracks, const std::vector<bool>& use,
                                      const SparseState& state,
                                      const BundleAdjustmentOptions& options,
                                      const BootstrapBiasOptions& bootstrap) {
  RequireEstimatedIntrinsics(options, "EstimateIntrinsicsBias");
  const double noise_px = ResidualNoisePx(tracks, use, state, options);
  const int replicas = bootstrap.replicas;
  BundleAdjustmentOptions replica_options = options;
  replica_options.num_threads = 1;  // the replicas share the pool instead
  // What the replicas share, made once; each adds noise of its own.
  const FeatureTracks explained = ExplainedTracks(tracks, use, state);
  std::vector<SparseState> adjusted(replicas, state);
  std::vector<ReplicaEstimate> estimates(replicas);
  cv::parallel_for_(cv::Range(0, replicas), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      const FeatureTracks replica = ReplicaTracks(explained, use, noise_px, bootstrap.seed, r);
      const BundleAdjustmentSummary summary =
          RunBundleAdjustment(replica, use, &adjusted[r], replica_options);
      estimates[r] = {adjusted[r].camera, adjusted[r].readout,
                      std::isfinite(summary.final_cost) && std::isfinite(adjusted[r].camera.f) &&
                          adjusted[r].camera.f > 0.0};
    }
  });
  IntrinsicsBias bias = MeanShift(estimates, state.camera, state.readout, bootstrap);
  bias.noise_px = noise_px;
  return bias;
}

bool BiasMatters(double sigma_f_noise_px, double f, const BootstrapBiasOptions& bootstrap) {
  return 100.0 * sigma_f_noise_px / f >= bootstrap.min_sigma_f_percent;
}

IntrinsicsBias MeanShift(const std::vector<ReplicaEstimate>& replicas, const CameraModel& camera,
                         double readout, const BootstrapBiasOptions& bootstrap) {
  IntrinsicsBias bias;
  // Whole pairs only: a pair's shifts linear in the noise cancel only when
  // both of its replicas solved.
  for (size_t r = 0; r + 1 < replicas.size(); r += 2) {
    if (!replicas[r].solved || !replicas[r + 1].solved) continue;
    for (const ReplicaEstimate& replica : {replicas[r], replicas[r + 1]}) {
      ++bias.replicas;
      bias.f += replica.camera.f - camera.f;
      bias.k1 += replica.camera.k1 - camera.k1;
      bias.k2 += replica.camera.k2 - camera.k2;
      bias.readout += replica.readout - readout;
    }
  }
  if (bias.replicas > 0) {
    bias.f /= bias.replicas;
    bias.k1 /= bias.replicas;
    bias.k2 /= bias.replicas;
    bias.readout /= bias.replicas;
  }
  bias.usable = bias.replicas > 0 && 2 * bias.replicas >= static_cast<int>(replicas.size()) &&
                std::abs(bias.f) <= bootstrap.max_correction_percent / 100.0 * camera.f;
  return bias;
}

std::optional<IntrinsicsBias> MeasureBiasIfItMatters(const FeatureTracks& tracks,
                                                     const std::vector<bool>& use,
                                                     const SparseState& state,
                                                     const BundleAdjustmentOptions& options,
                                                     const BootstrapBiasOptions& bootstrap) {
  RequireEstimatedIntrinsics(options, "MeasureBiasIfItMatters");
  if (bootstrap.replicas == 0) return std::nullopt;
  // sigma_f from the tracks' noise alone: no inflation, no wide-angle factor.
  BundleAdjustmentOptions evaluate = options;
  evaluate.max_iterations = 0;
  evaluate.uncertainty_inflation = 1.0;
  evaluate.wide_angle_inflation_exponent = 0.0;
  CalibrationUncertainty uncertainty;
  SparseState at = state;
  RunBundleAdjustment(tracks, use, &at, evaluate, &uncertainty);
  if (!uncertainty.available) return std::nullopt;
  const double sigma_f = uncertainty.sigma_f_px();
  if (!BiasMatters(sigma_f, state.camera.f, bootstrap)) return std::nullopt;
  IntrinsicsBias bias = EstimateIntrinsicsBias(tracks, use, state, options, bootstrap);
  bias.sigma_f_noise_px = sigma_f;
  return bias;
}

CameraModel Debiased(const CameraModel& camera, const std::optional<IntrinsicsBias>& bias) {
  if (!bias || !bias->usable) return camera;
  CameraModel debiased = camera;
  debiased.f -= bias->f;
  debiased.k1 -= bias->k1;
  debiased.k2 -= bias->k2;
  return debiased;
}

}  // namespace dfsm
