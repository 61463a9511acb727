#include "core/sparse/calibration_uncertainty.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/calibration_quality.h"
#include "core/sparse/rank_one_init.h"
#include "core/sparse/rotation_init.h"
#include "core/sparse/track_simulator.h"

namespace dfsm {
namespace {

struct Trial {
  CameraModel camera;
  CalibrationUncertainty uncertainty;
};

Trial AdjustSimulation(const TrackSimulatorOptions& options) {
  const TrackSimulation sim = SimulateTracks(options);
  SparseState state;
  state.camera = CameraModel::Initial(sim.camera.width, sim.camera.height);
  const RankOneResult init =
      RankOneInit(sim.tracks, state.camera, EstimateRotations(sim.tracks, state.camera));
  EXPECT_TRUE(init.ok);
  state.poses = init.poses;
  state.inverse_depths = init.inverse_depths;
  Trial trial;
  BundleAdjustmentOptions bare;  // the covariance itself, without the model-error inflation
  bare.uncertainty_inflation = 1.0;
  RunBundleAdjustment(sim.tracks, init.inliers, &state, bare, &trial.uncertainty);
  trial.camera = state.camera;
  return trial;
}

// The covariance is what repeated bursts of the same scene would show: over
// independent noise draws of one simulated scene, the spread of the estimated
// f matches the predicted sigma_f, and the normalized errors look like a unit
// Gaussian. (The scene stays; only the tracking noise changes.)
TEST(CalibrationUncertainty, PredictedSigmaMatchesTheSpreadOverNoiseDraws) {
  TrackSimulatorOptions options;
  options.width = 960;
  options.height = 540;
  options.f = 1050.0;
  options.tracks = 150;
  options.rotation_deg = 1.0;
  options.noise_px = 0.05;
  constexpr int kTrials = 30;
  double sum = 0.0, sum_sq = 0.0, predicted = 0.0, distortion_sigma = 0.0;
  int within_2_sigma = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    // Same scene and motion, other noise: SimulateTracks draws the scene from
    // `seed` and the noise after it, so vary only the noise.
    options.seed = 1;
    TrackSimulatorOptions noisy = options;
    noisy.noise_seed = 100 + trial;
    const Trial result = AdjustSimulation(noisy);
    ASSERT_TRUE(result.uncertainty.available) << result.uncertainty.unavailable_reason;
    const double error = result.camera.f - options.f;
    sum += error;
    sum_sq += error * error;
    predicted += result.uncertainty.sigma_f_px() / kTrials;
    distortion_sigma += result.uncertainty.distortion_sigma_px / kTrials;
    within_2_sigma += std::abs(error) <= 2.0 * result.uncertainty.sigma_f_px();
    // The tracking noise per coordinate, recovered from residuals that carry
    // the reference pixel's noise too.
    EXPECT_NEAR(result.uncertainty.residual_sigma_px, 0.05, 0.01);
  }
  const double mean = sum / kTrials;
  const double spread = std::sqrt(sum_sq / kTrials - mean * mean);
  std::cout << "predicted sigma_f " << predicted << " px, observed spread " << spread
            << " px, mean error " << mean << " px, within 2 sigma " << within_2_sigma << "/"
            << kTrials << "\n";
  RecordProperty("predicted_sigma_f_px", std::to_string(predicted));
  RecordProperty("observed_spread_f_px", std::to_string(spread));
  EXPECT_GT(predicted, 0.6 * spread) << "predicted " << predicted << " observed " << spread;
  EXPECT_LT(predicted, 1.6 * spread) << "predicted " << predicted << " observed " << spread;
  EXPECT_GE(within_2_sigma, kTrials * 8 / 10);
  EXPECT_GT(distortion_sigma, 0.0);
}

// More noise, less rotation: a wider sigma, in proportion.
TEST(CalibrationUncertainty, SigmaGrowsWithNoiseAndShrinksWithRotation) {
  TrackSimulatorOptions options;
  options.width = 960;
  options.height = 540;
  options.f = 1050.0;
  options.tracks = 150;
  options.noise_px = 0.05;
  options.rotation_deg = 1.0;
  const double base = AdjustSimulation(options).uncertainty.sigma_f_px();
  options.noise_px = 0.1;
  const double noisier = AdjustSimulation(options).uncertainty.sigma_f_px();
  EXPECT_NEAR(noisier / base, 2.0, 0.4);
  options.noise_px = 0.05;
  options.rotation_deg = 0.25;
  const double less_rotation = AdjustSimulation(options).uncertainty.sigma_f_px();
  EXPECT_GT(less_rotation, 2.0 * base);
}

// The inflation for model error scales the data's share: without priors that
// is every sigma, times the factor.
TEST(CalibrationUncertainty, InflationScalesTheDataShare) {
  TrackSimulatorOptions options;
  options.noise_px = 0.05;
  const TrackSimulation sim = SimulateTracks(options);
  SparseState start;
  start.camera = CameraModel::Initial(sim.camera.width, sim.camera.height);
  const RankOneResult init =
      RankOneInit(sim.tracks, start.camera, EstimateRotations(sim.tracks, start.camera));
  start.poses = init.poses;
  start.inverse_depths = init.inverse_depths;
  BundleAdjustmentOptions options_1, options_3;
  options_1.log_f_prior_sigma = options_3.log_f_prior_sigma = 0.0;  // no prior
  options_1.uncertainty_inflation = 1.0;
  options_3.uncertainty_inflation = 3.0;
  SparseState a = start, b = start;
  CalibrationUncertainty u1, u3;
  RunBundleAdjustment(sim.tracks, init.inliers, &a, options_1, &u1);
  RunBundleAdjustment(sim.tracks, init.inliers, &b, options_3, &u3);
  ASSERT_TRUE(u1.available && u3.available);
  EXPECT_NEAR(u3.sigma_f_px() / u1.sigma_f_px(), 3.0, 1e-6);
  EXPECT_NEAR(u3.distortion_sigma_px / u1.distortion_sigma_px, 3.0, 1e-6);
  EXPECT_EQ(u3.inflation, 3.0);
}

// Adjusts a simulated burst from its rank-1 start with the true intrinsics
// held fixed (and the readout estimated, if asked); returns the adjusted
// state and the uncertainty.
SparseState AdjustWithHeldIntrinsics(const TrackSimulation& sim, bool estimate_readout,
                                     CalibrationUncertainty* uncertainty) {
  SparseState state;
  state.camera = sim.camera;
  const RankOneResult init =
      RankOneInit(sim.tracks, state.camera, EstimateRotations(sim.tracks, state.camera));
  state.poses = init.poses;
  state.inverse_depths = init.inverse_depths;
  BundleAdjustmentOptions held;
  held.fix_intrinsics = true;
  held.estimate_readout = estimate_readout;
  RunBundleAdjustment(sim.tracks, init.inliers, &state, held, uncertainty);
  return state;
}

TEST(CalibrationUncertainty, HeldIntrinsicsHaveNoUncertainty) {
  TrackSimulatorOptions options;
  options.noise_px = 0.05;
  const TrackSimulation sim = SimulateTracks(options);
  CalibrationUncertainty uncertainty;
  const SparseState state = AdjustWithHeldIntrinsics(sim, false, &uncertainty);
  EXPECT_FALSE(uncertainty.available);
  EXPECT_EQ(uncertainty.unavailable_reason, "the intrinsics were held fixed");
  EXPECT_EQ(uncertainty.sigma_readout, -1.0);  // not estimated
  EXPECT_EQ(state.camera.f, sim.camera.f);
  EXPECT_EQ(state.camera.k1, sim.camera.k1);
}

// A known calibration held fixed while the readout is estimated: the
// intrinsics have no covariance, the readout still gets its sigma.
TEST(CalibrationUncertainty, AnEstimatedReadoutHasASigmaUnderHeldIntrinsics) {
  TrackSimulatorOptions options;
  options.noise_px = 0.05;
  options.rotation_deg = 1.0;
  options.readout = 0.6;
  const TrackSimulation sim = SimulateTracks(options);
  CalibrationUncertainty uncertainty;
  const SparseState state = AdjustWithHeldIntrinsics(sim, true, &uncertainty);
  EXPECT_FALSE(uncertainty.available);
  EXPECT_EQ(uncertainty.unavailable_reason, "the intrinsics were held fixed");
  EXPECT_GT(uncertainty.sigma_readout, 0.0);
  EXPECT_LT(uncertainty.sigma_readout, 0.05);
  EXPECT_LT(std::abs(state.readout - 0.6), 4.0 * uncertainty.sigma_readout + 0.005);
}

TEST(CalibrationQuality, AFoldingLensIsDegenerateWhateverItsSigma) {
  CameraModel camera = CameraModel::Initial(640, 480);
  camera.k1 = -1.0;  // 1 + 3 k1 r^2 < 0 beyond r = 0.58, inside the corner (0.63)
  camera.k2 = 0.0;
  double fold_px = 0.0;
  EXPECT_FALSE(RadialModelIsMonotone(camera, &fold_px));
  EXPECT_GT(fold_px, 0.0);
  CalibrationUncertainty tight;
  tight.available = true;
  tight.covariance = Eigen::Matrix3d::Identity() * 1e-12;
  CalibrationEvidence evidence;
  evidence.tracks = 300;
  evidence.median_track_motion_px = 3.0;
  const CalibrationVerdict verdict = JudgeCalibration(camera, tight, evidence);
  EXPECT_EQ(verdict.quality, CalibrationQuality::kDegenerate);
  ASSERT_FALSE(verdict.reasons.empty());
  EXPECT_NE(verdict.reasons[0].find("lens model folds"), std::string::npos) << verdict.reasons[0];
}

TEST(CalibrationQuality, NamesEveryReasonAndTellsUncertainFromReliable) {
  CameraModel camera = CameraModel::Initial(640, 480);
  CalibrationUncertainty uncertainty;
  uncertainty.available = true;
  uncertainty.covariance(0, 0) = std::pow(0.002 * camera.f, 2);  // 0.2 %
  uncertainty.distortion_sigma_px = 0.1;
  CalibrationEvidence evidence;
  evidence.tracks = 300;
  evidence.rms_reprojection_px = 0.1;
  evidence.median_track_motion_px = 3.0;
  CalibrationVerdict verdict = JudgeCalibration(camera, uncertainty, evidence);
  EXPECT_EQ(verdict.quality, CalibrationQuality::kReliable);
  EXPECT_TRUE(verdict.reasons.empty());
  evidence.tracks = 30;
  evidence.rms_reprojection_px = 0.9;
  uncertainty.covariance(0, 0) = std::pow(0.02 * camera.f, 2);  // 2 %
  verdict = JudgeCalibration(camera, uncertainty, evidence);
  EXPECT_EQ(verdict.quality, CalibrationQuality::kUncertain);
  ASSERT_EQ(verdict.reasons.size(), 3u);
  EXPECT_EQ(verdict.reasons[0], "weak focal length: sigma_f 2.00 % > 0.50 %");
  EXPECT_EQ(verdict.reasons[1], "few tracks: 30 < 60");
  EXPECT_EQ(verdict.reasons[2], "high residual: RMS 0.90 px > 0.50 px");
  uncertainty.covariance(0, 0) = std::pow(0.2 * camera.f, 2);  // 20 %: the prior's
  EXPECT_EQ(JudgeCalibration(camera, uncertainty, evidence).quality,
            CalibrationQuality::kDegenerate);
}

TEST(CalibrationQuality, OptionsCheckNamesTheBadThreshold) {
  CalibrationQualityOptions options;
  options.Check();
  options.max_reliable_sigma_f_percent = 20.0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
