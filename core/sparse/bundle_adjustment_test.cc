#include "core/sparse/bundle_adjustment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>

#include "core/camera/rolling_shutter.h"
#include "core/sparse/intrinsics_prior.h"
#include "core/sparse/rank_one_init.h"
#include "core/sparse/rotation_init.h"
#include "tests/support/rank_one_start.h"
#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

// The weak prior in log f and the corner shift; a trust-region trial step
// that takes f through zero is refused (no NaN for Ceres to warn about).
TEST(IntrinsicsPrior, ScoresLogFocalAndCornerShiftAndRefusesFocalLengthsAtOrBelowZero) {
  CameraModel camera;
  camera.width = 640;
  camera.height = 480;
  camera.cx = 320;
  camera.cy = 240;
  camera.f = 500;
  const std::unique_ptr<ceres::CostFunction> prior(IntrinsicsPrior::Create(camera, 0.5, 0.1));
  double intrinsics[3] = {640.0 * std::exp(0.5), 0.0, 0.0};  // one sigma long, no distortion
  const double* parameters[] = {intrinsics};
  double residuals[3];
  ASSERT_TRUE(prior->Evaluate(parameters, residuals, nullptr));
  EXPECT_NEAR(residuals[0], 1.0, 1e-12);
  EXPECT_EQ(residuals[1], 0.0);
  EXPECT_EQ(residuals[2], 0.0);
  for (const double f : {0.0, -1630.0}) {  // -1630: a step seen on a wide-angle sweep burst
    intrinsics[0] = f;
    intrinsics[1] = 5.86;
    intrinsics[2] = 0.13;
    EXPECT_FALSE(prior->Evaluate(parameters, residuals, nullptr)) << f;
  }
}

struct Errors {
  double focal_percent, distortion_px, rotation_deg;
};

Errors Compare(const SparseState& state, const TrackSimulation& sim) {
  Errors errors{};
  errors.focal_percent = 100.0 * std::abs(state.camera.f - sim.camera.f) / sim.camera.f;
  errors.distortion_px = MeanDistortionError(state.camera, sim.camera);
  for (size_t i = 1; i < sim.poses.size(); ++i)
    errors.rotation_deg += RotationErrorDeg(state.poses[i].R, sim.poses[i].R);
  errors.rotation_deg /= sim.poses.size() - 1;
  return errors;
}

// f is observable in a small-motion burst only through the second-order terms
// of the rotational flow (f * theta * x^2, a few pixels at the image edge for a
// 1 deg tremor), so its accuracy scales with tracking noise over rotation: 1 %
// needs KLT-grade tracks (~0.02 px at 1080p) and about a degree of rotation.
TEST(BundleAdjustment, SelfCalibratesFromTheRankOneStart) {
  for (const uint64_t seed : {1, 2, 3}) {
    TrackSimulatorOptions options;
    options.noise_px = 0.02;
    options.rotation_deg = 1.0;
    options.seed = seed;
    const TrackSimulation sim = SimulateTracks(options);
    std::vector<bool> use;
    SparseState state = RankOneStart(sim, &use);
    const BundleAdjustmentSummary summary = RunBundleAdjustment(sim.tracks, use, &state);
    const Errors errors = Compare(state, sim);
    EXPECT_TRUE(summary.converged) << summary.termination;
    EXPECT_LE(summary.iterations, 25);  // the paper: 10-25 from the rank-1 start
    EXPECT_LT(summary.final_cost, summary.initial_cost);
    EXPECT_LT(summary.rms_reprojection_px, 0.05);
    EXPECT_LT(errors.focal_percent, 1.0) << "seed " << seed << " f " << state.camera.f;
    EXPECT_LT(errors.distortion_px, 0.5) << "seed " << seed;
    EXPECT_LT(errors.rotation_deg, 0.05) << "seed " << seed;
  }
}

// The covariance's noise inflation grows for a wide lens it estimated only: a
// camera at or above 0.9 x its longer side keeps the measured 2.8; at 0.6 x
// it takes 2.8 (0.9 / 0.6)^4; the ratio is of the longer side, portrait or
// not.
TEST(BundleAdjustment, UncertaintyInflationGrowsForAWideLensOnly) {
  BundleAdjustmentOptions options;
  CameraModel camera = CameraModel::Initial(1920, 1080);
  for (const double ratio : {1.5, 1.1, 0.9}) {
    camera.f = ratio * 1920;
    EXPECT_DOUBLE_EQ(UncertaintyInflation(options, camera), options.uncertainty_inflation);
  }
  camera.f = 0.6 * 1920;
  EXPECT_NEAR(UncertaintyInflation(options, camera), 2.8 * std::pow(1.5, 4), 1e-9);
  CameraModel portrait = CameraModel::Initial(1080, 1920);
  portrait.f = camera.f;
  EXPECT_DOUBLE_EQ(UncertaintyInflation(options, portrait), UncertaintyInflation(options, camera));
  // A camera held, or given as a prior, is not the biased estimate.
  BundleAdjustmentOptions held = options, prior = options;
  held.fix_intrinsics = true;
  prior.known_f_sigma_percent = 2.0;
  EXPECT_DOUBLE_EQ(UncertaintyInflation(held, camera), options.uncertainty_inflation);
  EXPECT_DOUBLE_EQ(UncertaintyInflation(prior, camera), options.uncertainty_inflation);
  options.wide_angle_inflation_exponent = 0.0;
  EXPECT_DOUBLE_EQ(UncertaintyInflation(options, camera), options.uncertainty_inflation);
  // The same inflation reaches the covariance the adjustment reports, for a
  // simulated wide lens (0.6 x the width).
  TrackSimulatorOptions simulated;
  simulated.noise_px = 0.05;
  simulated.seed = 4;
  simulated.f = 0.6 * simulated.width;
  const TrackSimulation sim = SimulateTracks(simulated);
  std::vector<bool> use;
  SparseState state = RankOneStart(sim, &use);
  const BundleAdjustmentOptions with_covariance;
  CalibrationUncertainty uncertainty;
  RunBundleAdjustment(sim.tracks, use, &state, with_covariance, &uncertainty);
  EXPECT_GT(uncertainty.inflation, 1.5 * with_covariance.uncertainty_inflation) << state.camera.f;
  EXPECT_DOUBLE_EQ(uncertainty.inflation, UncertaintyInflation(with_covariance, state.camera));
  EXPECT_DOUBLE_EQ(uncertainty.wide_angle_factor, WideAngleFactor(with_covariance, state.camera));
  EXPECT_NEAR(uncertainty.inflation,
              with_covariance.uncertainty_inflation * uncertainty.wide_angle_factor, 1e-12);
}

// Inverse depths held (a depth given from elsewhere): they come out exactly
// as given, and the poses adjust to them. From the true depths and the true
// camera, a start with the poses knocked off returns to the true rotations;
// from depths 20 % off, every other track nearer and the rest farther (no
// change of scale or offset the poses could take up), the tracks fit worse.
TEST(BundleAdjustment, HoldsInverseDepthsWhereAsked) {
  TrackSimulatorOptions options;
  options.noise_px = 0.02;
  options.rotation_deg = 1.0;
  options.seed = 5;
  const TrackSimulation sim = SimulateTracks(options);
  const std::vector<bool> use(sim.tracks.num_tracks(), true);
  BundleAdjustmentOptions held;
  held.fix_intrinsics = true;
  held.hold_inverse_depths = true;
  auto start = [&](double depth_error) {
    SparseState state;
    state.camera = sim.camera;
    state.poses = sim.poses;
    for (size_t i = 1; i < state.poses.size(); ++i)
      state.poses[i].R = state.poses[i].R * Eigen::AngleAxisd(0.002, Eigen::Vector3d::UnitY());
    for (size_t j = 0; j < sim.inverse_depths.size(); ++j)
      state.inverse_depths.push_back(sim.inverse_depths[j] *
                                     (j % 2 ? 1.0 + depth_error : 1.0 / (1.0 + depth_error)));
    return state;
  };
  SparseState truth = start(0.0), off = start(0.2);
  const std::vector<double> given = off.inverse_depths;
  const BundleAdjustmentSummary at_truth = RunBundleAdjustment(sim.tracks, use, &truth, held);
  const BundleAdjustmentSummary at_off = RunBundleAdjustment(sim.tracks, use, &off, held);
  EXPECT_EQ(off.inverse_depths, given);
  EXPECT_LT(at_truth.rms_reprojection_px, 0.05);
  EXPECT_LT(Compare(truth, sim).rotation_deg, 0.01);
  EXPECT_GT(at_off.rms_reprojection_px, 2.0 * at_truth.rms_reprojection_px);
  CalibrationUncertainty uncertainty;
  EXPECT_THROW(RunBundleAdjustment(sim.tracks, use, &off, held, &uncertainty),
               std::invalid_argument);
}

TEST(BundleAdjustment, ReportsReprojectionErrorPerTrack) {
  TrackSimulatorOptions options;
  options.seed = 4;
  const TrackSimulation sim = SimulateTracks(options);
  SparseState truth = SimulatedState(sim);
  for (const double error : TrackReprojectionErrors(sim.tracks, truth)) EXPECT_LT(error, 1e-6);
  truth.inverse_depths[0] *= 1.5;
  EXPECT_GT(TrackReprojectionErrors(sim.tracks, truth)[0], 0.5);
}

// A stale inverse depth (a track an outlier round dropped keeps the depth
// of the round before, a probe's left-out track the start's) is refitted:
// the error at the best depth is at most the error at the true depth, and
// the depth returned is the true one to within the noise, under a global
// and a rolling shutter, from 1.5x, 0.5x and 0.02x the true depth.
TEST(BundleAdjustment, ReportsReprojectionErrorPerTrackAtItsBestDepth) {
  for (const double readout : {0.0, 0.6}) {
    TrackSimulatorOptions options;
    options.seed = 4;
    options.rotation_deg = 1.0;
    options.noise_px = 0.1;
    options.readout = readout;
    const TrackSimulation sim = SimulateTracks(options);
    const SparseState truth = SimulatedState(sim, readout);
    const std::vector<double> at_truth = TrackReprojectionErrors(sim.tracks, truth);
    std::vector<double> depths;
    const std::vector<double> best = TrackReprojectionErrorsAtBestDepth(sim.tracks, truth, &depths);
    ASSERT_EQ(best.size(), at_truth.size());
    ASSERT_EQ(depths.size(), at_truth.size());
    for (size_t j = 0; j < best.size(); ++j)
      EXPECT_LE(best[j], at_truth[j] + 1e-12) << "track " << j;
    SparseState stale = truth;
    const double factors[] = {1.5, 0.5, 0.02};
    for (int j = 0; j < 3; ++j) stale.inverse_depths[j] *= factors[j];
    const std::vector<double> stale_plain = TrackReprojectionErrors(sim.tracks, stale);
    const std::vector<double> refitted =
        TrackReprojectionErrorsAtBestDepth(sim.tracks, stale, &depths);
    for (int j = 0; j < 3; ++j) {
      EXPECT_GT(stale_plain[j], 0.5) << "readout " << readout << " track " << j;
      EXPECT_LE(refitted[j], at_truth[j] + 1e-9) << "readout " << readout << " track " << j;
      EXPECT_NEAR(depths[j], sim.inverse_depths[j], 0.05 * sim.inverse_depths[j])
          << "readout " << readout << " track " << j;
    }
  }
}

// A phone's rolling shutter (readout 0.6 of the frame interval) seen as a
// global shutter shears every frame by its motion during the readout, which
// the adjustment can only absorb into f and k: the rolling-shutter residuals
// remove that, whether the readout is known or estimated.
TEST(BundleAdjustment, RollingShutterIsModelledKnownOrEstimated) {
  double worst_global_percent = 0.0;
  for (const uint64_t seed : {1, 2, 3}) {
    TrackSimulatorOptions options;
    options.noise_px = 0.02;
    options.rotation_deg = 1.0;
    options.readout = 0.6;
    options.seed = seed;
    const TrackSimulation sim = SimulateTracks(options);
    std::vector<bool> use;
    SparseState global = RankOneStart(sim, &use);
    SparseState known = global, estimated = global;
    RunBundleAdjustment(sim.tracks, use, &global);
    known.readout = 0.6;
    RunBundleAdjustment(sim.tracks, use, &known);
    BundleAdjustmentOptions estimate;
    estimate.estimate_readout = true;
    CalibrationUncertainty uncertainty;
    const BundleAdjustmentSummary summary =
        RunBundleAdjustment(sim.tracks, use, &estimated, estimate, &uncertainty);
    const Errors as_global = Compare(global, sim), with_known = Compare(known, sim),
                 with_estimate = Compare(estimated, sim);
    std::printf(
        "seed %d: f error as global %.2f %%, known %.2f %%, estimated %.2f %% (readout %.3f)\n",
        static_cast<int>(seed), as_global.focal_percent, with_known.focal_percent,
        with_estimate.focal_percent, estimated.readout);
    worst_global_percent = std::max(worst_global_percent, as_global.focal_percent);
    EXPECT_LT(with_known.focal_percent, 1.0) << "seed " << seed << " f " << known.camera.f;
    EXPECT_LT(with_known.rotation_deg, 0.05) << "seed " << seed;
    EXPECT_NEAR(estimated.readout, 0.6, 0.05) << "seed " << seed;
    EXPECT_LT(with_estimate.focal_percent, 1.0) << "seed " << seed << " f " << estimated.camera.f;
    EXPECT_LT(with_estimate.distortion_px, 0.5) << "seed " << seed;
    EXPECT_LT(summary.rms_reprojection_px, 0.05) << "seed " << seed;
    EXPECT_TRUE(uncertainty.available);
    // The readout's own sigma, and the estimate within a few of it.
    EXPECT_GT(uncertainty.sigma_readout, 0.0) << "seed " << seed;
    EXPECT_LT(std::abs(estimated.readout - 0.6), 4.0 * uncertainty.sigma_readout + 0.005)
        << "seed " << seed << " sigma " << uncertainty.sigma_readout;
    // The per-track errors judge outliers under the same shutter.
    const std::vector<double> errors = TrackReprojectionErrors(sim.tracks, estimated);
    for (size_t j = 0; j < errors.size(); ++j)
      if (use[j]) {
        EXPECT_LT(errors[j], 0.2) << "seed " << seed << " track " << j;
      }
  }
  EXPECT_GT(worst_global_percent, 3.0);
  // A global shutter's burst estimates no readout to speak of.
  TrackSimulatorOptions options;
  options.noise_px = 0.02;
  options.rotation_deg = 1.0;
  const TrackSimulation sim = SimulateTracks(options);
  std::vector<bool> use;
  SparseState state = RankOneStart(sim, &use);
  BundleAdjustmentOptions estimate;
  estimate.estimate_readout = true;
  RunBundleAdjustment(sim.tracks, use, &state, estimate);
  EXPECT_LT(state.readout, 0.05);
  EXPECT_LT(Compare(state, sim).focal_percent, 1.0) << "f " << state.camera.f;
}

// The median relative error of the inverse depths `use` marks, after the
// scale that fits them to the truth best (the adjustment's gauge).
double MedianRelativeDepthError(const SparseState& state, const TrackSimulation& sim,
                                const std::vector<bool>& use) {
  double numerator = 0.0, denominator = 0.0;
  for (size_t j = 0; j < use.size(); ++j)
    if (use[j]) {
      numerator += state.inverse_depths[j] * sim.inverse_depths[j];
      denominator += state.inverse_depths[j] * state.inverse_depths[j];
    }
  const double scale = numerator / denominator;
  std::vector<double> errors;
  for (size_t j = 0; j < use.size(); ++j)
    if (use[j])
      errors.push_back(std::abs(scale * state.inverse_depths[j] / sim.inverse_depths[j] - 1.0));
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

// Each frame's angular velocity: its neighbours' rotation step (the line
// between frame poses) plus a turn of `bend_px` at f per frame interval
// whose sign alternates from frame to frame, as a hand's tremor reverses
// within a few frames.
std::vector<Eigen::Vector3d> BentVelocities(const TrackSimulation& sim, double bend_px) {
  const int n = static_cast<int>(sim.poses.size());
  std::vector<Eigen::Vector3d> velocities(n);
  for (int i = 0; i < n; ++i) {
    const int after = std::min(i + 1, n - 1), before = std::max(i - 1, 0);
    velocities[i] = (ToPoseParameters(sim.poses[after]).head<3>() -
                     ToPoseParameters(sim.poses[before]).head<3>()) /
                    (after - before);
    const Eigen::Vector3d axis = Eigen::Vector3d(1.0, 0.6 * std::cos(i), 0.2).normalized();
    velocities[i] += (i % 2 == 0 ? 1.0 : -1.0) * bend_px / sim.camera.f * axis;
  }
  return velocities;
}

// With the camera known, rows that turn at their frame's own velocity are
// fitted to the tracks' noise by the per-frame velocities, and the relief
// with them, where the line between frame poses leaves a bend of 3 px per
// frame interval to the translations and the depths (2-11 % against 0.5-0.7 %).
// A path that turns steadily through each frame (no bend) costs neither.
// Rows that follow the line itself, with its kink at every frame's middle
// row (no hand moves so), cost the velocities: 0.4-0.6 % -> 1.0-1.9 %.
TEST(BundleAdjustment, AKnownCameraFollowsRowsThatTurnAtTheirOwnVelocity) {
  enum class Path { kLine, kSteady, kBent };
  for (const uint64_t seed : {1, 2, 3}) {
    for (const Path path : {Path::kLine, Path::kSteady, Path::kBent}) {
      TrackSimulatorOptions options;
      options.noise_px = 0.05;
      options.rotation_deg = 1.0;
      options.readout = 0.6;
      options.seed = seed;
      if (path != Path::kLine)
        options.angular_velocities =
            BentVelocities(SimulateTracks(options), path == Path::kBent ? 3.0 : 0.0);
      const TrackSimulation sim = SimulateTracks(options);
      std::vector<bool> use;
      SparseState line = RankOneStart(sim, &use, &sim.camera);
      line.readout = 0.6;
      SparseState turning = line;
      BundleAdjustmentOptions held;
      held.fix_intrinsics = true;
      const BundleAdjustmentSummary line_summary =
          RunBundleAdjustment(sim.tracks, use, &line, held);
      held.angular_velocity_sigma_px = 2.0;
      const BundleAdjustmentSummary turning_summary =
          RunBundleAdjustment(sim.tracks, use, &turning, held);
      const double line_error = MedianRelativeDepthError(line, sim, use),
                   turning_error = MedianRelativeDepthError(turning, sim, use);
      std::printf("seed %d path %d: RMS line %.3f px, velocities %.3f px; depth %.2f %%, %.2f %%\n",
                  static_cast<int>(seed), static_cast<int>(path), line_summary.rms_reprojection_px,
                  turning_summary.rms_reprojection_px, 100.0 * line_error, 100.0 * turning_error);
      ASSERT_EQ(turning.angular_velocities.size(), sim.poses.size());
      EXPECT_TRUE(line.angular_velocities.empty());
      const std::string where =
          "seed " + std::to_string(seed) + " path " + std::to_string(static_cast<int>(path));
      switch (path) {
        case Path::kBent:
          EXPECT_LT(turning_summary.rms_reprojection_px, 0.1) << where;
          EXPECT_GT(line_summary.rms_reprojection_px, 4.0 * turning_summary.rms_reprojection_px)
              << where;
          EXPECT_LT(turning_error, 0.5 * line_error) << where;
          EXPECT_LT(turning_error, 0.01) << where;
          break;
        case Path::kSteady:
          EXPECT_LT(turning_summary.rms_reprojection_px, line_summary.rms_reprojection_px) << where;
          EXPECT_LT(turning_error, 0.01) << where;
          EXPECT_LT(line_error, 0.01) << where;
          break;
        case Path::kLine:
          EXPECT_LT(turning_error, 0.025) << where;
          EXPECT_LT(line_error, 0.01) << where;
          break;
      }
    }
  }
}

// A negative readout (a sensor read bottom-up) is a rolling shutter too: the
// per-track errors that judge outliers must not fall back to a global one.
TEST(BundleAdjustment, ANegativeReadoutIsARollingShutter) {
  TrackSimulatorOptions options;
  options.rotation_deg = 1.0;
  const TrackSimulation sim = SimulateTracks(options);
  const SparseState truth = SimulatedState(sim, -0.6);
  double largest = 0.0;
  for (const double error : TrackReprojectionErrors(sim.tracks, truth))
    largest = std::max(largest, error);
  EXPECT_GT(largest, 0.1);  // the global-shutter tracks no longer fit
}

TEST(BundleAdjustment, NaiveStartNeedsFarMoreIterations) {
  TrackSimulatorOptions options;
  options.noise_px = 0.1;
  const TrackSimulation sim = SimulateTracks(options);
  std::vector<bool> use;
  SparseState rank1 = RankOneStart(sim, &use);
  const auto rank1_summary = RunBundleAdjustment(sim.tracks, use, &rank1);

  SparseState naive;
  naive.camera = CameraModel::Initial(sim.camera.width, sim.camera.height);
  naive.poses.assign(sim.poses.size(), Pose{});
  std::mt19937_64 random(0);
  std::uniform_real_distribution<double> uniform(0.01, 1.0);
  for (int j = 0; j < sim.tracks.num_tracks(); ++j) naive.inverse_depths.push_back(uniform(random));
  const auto naive_summary =
      RunBundleAdjustment(sim.tracks, std::vector<bool>(sim.tracks.num_tracks(), true), &naive);
  EXPECT_TRUE(rank1_summary.converged);
  EXPECT_TRUE(!naive_summary.converged || naive_summary.iterations > rank1_summary.iterations)
      << "naive " << naive_summary.iterations << " rank1 " << rank1_summary.iterations;
}

// distortion_terms = 3 used to free every term silently: every option out of
// range is refused with its name.
TEST(BundleAdjustment, OptionsOutOfRangeAreNamed) {
  const auto message = [](const BundleAdjustmentOptions& options) {
    try {
      options.Check();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(BundleAdjustmentOptions{}), "no error");
  BundleAdjustmentOptions options;
  options.distortion_terms = 3;
  EXPECT_NE(message(options).find("distortion_terms"), std::string::npos);
  options = {};
  options.huber_px = std::nan("");
  EXPECT_NE(message(options).find("huber_px"), std::string::npos);
  options = {};
  options.uncertainty_inflation = 0.5;
  EXPECT_NE(message(options).find("uncertainty_inflation"), std::string::npos);
  options = {};
  options.max_iterations = -1;
  EXPECT_NE(message(options).find("max_iterations"), std::string::npos);
  options.max_iterations = 0;  // evaluates the state only
  EXPECT_EQ(message(options), "no error");
}

}  // namespace
}  // namespace dfsm
