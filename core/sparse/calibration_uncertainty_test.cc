#include "core/sparse/calibration_uncertainty.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <utility>
#include <vector>

#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/calibration_quality.h"
#include "tests/support/rank_one_start.h"
#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

struct Trial {
  SparseState state;  // adjusted
  std::vector<bool> inliers;
  CalibrationUncertainty uncertainty;
};

// Adjusts simulated tracks from their rank-1 start, the camera at the generic
// initial guess.
Trial AdjustTracks(const TrackSimulation& sim, const BundleAdjustmentOptions& options) {
  Trial trial;
  trial.state = RankOneStart(sim, &trial.inliers);
  RunBundleAdjustment(sim.tracks, trial.inliers, &trial.state, options, &trial.uncertainty);
  return trial;
}

Trial AdjustSimulation(const TrackSimulatorOptions& options) {
  BundleAdjustmentOptions bare;  // the covariance itself, without the model-error inflation
  bare.uncertainty_inflation = 1.0;
  return AdjustTracks(SimulateTracks(options), bare);
}

// Adjusts a simulated burst from its rank-1 start with the true intrinsics
// held fixed (and the readout estimated, if asked); returns the adjusted
// state and the uncertainty.
SparseState AdjustWithHeldIntrinsics(const TrackSimulation& sim, bool estimate_readout,
                                     CalibrationUncertainty* uncertainty) {
  std::vector<bool> use;
  SparseState state = RankOneStart(sim, &use, &sim.camera);
  BundleAdjustmentOptions held;
  held.fix_intrinsics = true;
  held.estimate_readout = estimate_readout;
  RunBundleAdjustment(sim.tracks, use, &state, held, uncertainty);
  return state;
}

// The scene of the noise-draw tests: 960x540, f 1050, 150 tracks, 1 deg of
// tremor.
TrackSimulatorOptions NoiseDrawScene(double noise_px) {
  TrackSimulatorOptions options;
  options.width = 960;
  options.height = 540;
  options.f = 1050.0;
  options.tracks = 150;
  options.rotation_deg = 1.0;
  options.noise_px = noise_px;
  return options;
}

// The covariance is what repeated bursts of the same scene would show: over
// independent noise draws of one simulated scene, the spread of the estimated
// f matches the predicted sigma_f, and the normalized errors look like a unit
// Gaussian. (The scene stays; only the tracking noise changes.)
TEST(CalibrationUncertainty, PredictedSigmaMatchesTheSpreadOverNoiseDraws) {
  TrackSimulatorOptions options = NoiseDrawScene(0.05);
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
    const double error = result.state.camera.f - options.f;
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

// The relief: over noise draws of one scene, the tracks' relative inverse
// depth errors after one global scale. Their spread holds each track's own
// noise beside the camera's share that relief_sigma predicts, so the
// prediction stays below the whole spread; the camera's share is what the
// tracks have in common, so it is also seen in the errors smoothed over
// neighbouring tracks (ordered by inverse depth: the rotation-offset mode
// moves near and far tracks apart).
TEST(CalibrationUncertainty, ReliefSigmaMatchesTheSharedSpreadOverNoiseDraws) {
  TrackSimulatorOptions options = NoiseDrawScene(0.1);
  constexpr int kTrials = 30;
  constexpr size_t kGroup = 15;  // tracks of neighbouring inverse depth
  BundleAdjustmentOptions bare;
  bare.uncertainty_inflation = 1.0;
  double predicted = 0.0, total_sq = 0.0, smoothed_sq = 0.0;
  for (int trial = 0; trial < kTrials; ++trial) {
    options.seed = 1;
    TrackSimulatorOptions noisy = options;
    noisy.noise_seed = 200 + trial;
    const TrackSimulation sim = SimulateTracks(noisy);
    const Trial adjusted = AdjustTracks(sim, bare);
    const SparseState& state = adjusted.state;
    const std::vector<bool>& inliers = adjusted.inliers;
    const CalibrationUncertainty& uncertainty = adjusted.uncertainty;
    ASSERT_GT(uncertainty.relief_sigma, 0.0);
    predicted += uncertainty.relief_sigma / kTrials;
    std::vector<std::pair<double, double>> errors;  // (true w, log error)
    for (size_t j = 0; j < sim.inverse_depths.size(); ++j)
      if (inliers[j] && state.inverse_depths[j] > 0.0)
        errors.emplace_back(sim.inverse_depths[j],
                            std::log(state.inverse_depths[j] / sim.inverse_depths[j]));
    double mean = 0.0;
    for (const auto& e : errors) mean += e.second / errors.size();
    std::sort(errors.begin(), errors.end());
    for (size_t j = 0; j < errors.size(); ++j) {
      total_sq += std::pow(errors[j].second - mean, 2) / errors.size() / kTrials;
      const size_t group = j / kGroup * kGroup;
      if (j != group || group + kGroup > errors.size()) continue;
      double group_mean = 0.0;
      for (size_t k = group; k < group + kGroup; ++k) group_mean += errors[k].second / kGroup;
      smoothed_sq += std::pow(group_mean - mean, 2) / (errors.size() / kGroup) / kTrials;
    }
  }
  const double total = std::sqrt(total_sq), smoothed = std::sqrt(smoothed_sq);
  std::cout << "predicted relief sigma " << predicted << ", observed: all " << total
            << ", smoothed over " << kGroup << " tracks " << smoothed << "\n";
  RecordProperty("predicted_relief_sigma", std::to_string(predicted));
  RecordProperty("observed_relief_spread", std::to_string(total));
  EXPECT_LT(predicted, total);
  // Measured: 0.023 predicted, 0.026 smoothed (of which ~0.009 is the tracks'
  // own noise over 15 of them), 0.043 in all.
  EXPECT_GT(predicted, 0.6 * smoothed);
  EXPECT_LT(predicted, 1.6 * smoothed);
}

// Held intrinsics leave the poses' share: the relief sigma is still there,
// and smaller than with f, k1, k2 free.
TEST(CalibrationUncertainty, ReliefSigmaUnderHeldIntrinsics) {
  TrackSimulatorOptions options;
  options.noise_px = 0.05;
  const TrackSimulation sim = SimulateTracks(options);
  CalibrationUncertainty held;
  AdjustWithHeldIntrinsics(sim, false, &held);
  EXPECT_FALSE(held.available);
  EXPECT_GT(held.relief_sigma, 0.0);
  const CalibrationUncertainty free = AdjustTracks(sim, BundleAdjustmentOptions{}).uncertainty;
  EXPECT_GT(free.relief_sigma, held.relief_sigma);
}

// More noise, less rotation: a wider sigma, in proportion.
TEST(CalibrationUncertainty, SigmaGrowsWithNoiseAndShrinksWithRotation) {
  TrackSimulatorOptions options = NoiseDrawScene(0.05);
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
  std::vector<bool> use;
  const SparseState start = RankOneStart(sim, &use);
  BundleAdjustmentOptions options_1, options_3;
  options_1.log_f_prior_sigma = options_3.log_f_prior_sigma = 0.0;  // no prior
  options_1.uncertainty_inflation = 1.0;
  options_3.uncertainty_inflation = 3.0;
  SparseState a = start, b = start;
  CalibrationUncertainty u1, u3;
  RunBundleAdjustment(sim.tracks, use, &a, options_1, &u1);
  RunBundleAdjustment(sim.tracks, use, &b, options_3, &u3);
  ASSERT_TRUE(u1.available && u3.available);
  EXPECT_NEAR(u3.sigma_f_px() / u1.sigma_f_px(), 3.0, 1e-6);
  EXPECT_NEAR(u3.distortion_sigma_px / u1.distortion_sigma_px, 3.0, 1e-6);
  EXPECT_EQ(u3.inflation, 3.0);
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

// The verdict of `camera` where the burst measured it as tightly as it can
// be and with plenty of tracks and motion: only the camera itself can fail.
CalibrationVerdict JudgeAsIfTight(const CameraModel& camera) {
  CalibrationUncertainty tight;
  tight.available = true;
  tight.covariance = Eigen::Matrix3d::Identity() * 1e-12;
  CalibrationEvidence evidence;
  evidence.tracks = 300;
  evidence.median_track_motion_px = 3.0;
  return JudgeCalibration(camera, tight, evidence);
}

TEST(CalibrationQuality, AFoldingLensIsDegenerateWhateverItsSigma) {
  CameraModel camera = CameraModel::Initial(640, 480);
  camera.k1 = -1.0;  // 1 + 3 k1 r^2 < 0 beyond r = 0.58, inside the corner (0.63)
  camera.k2 = 0.0;
  double fold_px = 0.0;
  EXPECT_FALSE(RadialModelIsMonotone(camera, &fold_px));
  EXPECT_GT(fold_px, 0.0);
  const CalibrationVerdict verdict = JudgeAsIfTight(camera);
  EXPECT_EQ(verdict.quality, CalibrationQuality::kDegenerate);
  ASSERT_FALSE(verdict.reasons.empty());
  EXPECT_NE(verdict.reasons[0].find("lens model folds"), std::string::npos) << verdict.reasons[0];
  EXPECT_EQ(ImplausibleCamera(camera), std::vector<std::string>{verdict.reasons[0]});
}

// A focal length outside the plausible range is no camera's however tight its
// sigma: the verdict is degenerate for it, and ImplausibleCamera names it
// apart from the reasons a real camera can have.
TEST(CalibrationQuality, AnImplausibleFocalLengthIsNoCamerasWhateverItsSigma) {
  CameraModel camera = CameraModel::Initial(640, 480);
  EXPECT_TRUE(ImplausibleCamera(camera).empty());
  camera.f = 12.9 * 640;
  const std::vector<std::string> reasons = ImplausibleCamera(camera);
  ASSERT_EQ(reasons.size(), 1u);
  EXPECT_EQ(reasons[0],
            "implausible focal length: f 8256.0 px is 12.90 x the image size (expected "
            "0.20-10.00)");
  const CalibrationVerdict verdict = JudgeAsIfTight(camera);
  EXPECT_EQ(verdict.quality, CalibrationQuality::kDegenerate);
  EXPECT_EQ(verdict.reasons, reasons);
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
  verdict = JudgeCalibration(camera, uncertainty, evidence);
  EXPECT_EQ(verdict.quality, CalibrationQuality::kDegenerate);
  EXPECT_NE(verdict.reasons[0].find("the prior, not the burst, sets f"), std::string::npos);
  // A wide lens's sigma carries the wide-angle factor: the reason says so
  // instead of blaming the prior.
  uncertainty.wide_angle_factor = 3.2;
  verdict = JudgeCalibration(camera, uncertainty, evidence);
  EXPECT_EQ(verdict.quality, CalibrationQuality::kDegenerate);
  EXPECT_NE(verdict.reasons[0].find("a wide lens: the sigma is inflated 3.2x"), std::string::npos)
      << verdict.reasons[0];
  EXPECT_EQ(verdict.reasons[0].find("the prior"), std::string::npos) << verdict.reasons[0];
}

TEST(CalibrationQuality, OptionsCheckNamesTheBadThreshold) {
  CalibrationQualityOptions options;
  options.Check();
  options.max_reliable_sigma_f_percent = 20.0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
