#include "core/sparse/bootstrap_bias.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core/utility.hpp>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/sparse/sparse_reconstruction.h"
#include "tests/support/rank_one_start.h"
#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

// A 320x240 burst's tracks (there the noise moves f most: bootstrap_bias.h),
// with Gaussian noise of noise_px on each coordinate in every frame but the
// reference, whose pixels define the tracks.
TrackSimulation SmallBurst(uint64_t seed, double noise_px, double readout = 0.0, int frames = 10) {
  TrackSimulatorOptions options;
  options.width = 320;
  options.height = 240;
  options.f = 352.0;
  options.frames = frames;
  options.tracks = 200;
  options.readout = readout;
  options.seed = seed;
  TrackSimulation sim = SimulateTracks(options);
  std::mt19937_64 rng(seed + 100);
  std::normal_distribution<double> normal(0.0, noise_px);
  for (int i = 0; i < sim.tracks.num_frames(); ++i)
    if (i != sim.tracks.reference)
      for (int j = 0; j < sim.tracks.num_tracks(); ++j)
        sim.tracks.pixels[i].col(j) += Eigen::Vector2d(normal(rng), normal(rng));
  return sim;
}

// Replica tracks without noise are what the state predicts: its residuals
// on them vanish, under a global and a rolling shutter, while on the noisy
// tracks they are the noise; tracks not used keep their observations.
TEST(ReplicaTracks, WithoutNoiseTheStateExplainsThemExactly) {
  for (const double readout : {0.0, 0.6}) {
    const TrackSimulation sim = SmallBurst(1, 0.05, readout);
    const SparseState truth = SimulatedState(sim, readout);
    std::vector<bool> use(sim.tracks.num_tracks(), true);
    use[3] = false;
    const FeatureTracks replica =
        ReplicaTracks(ExplainedTracks(sim.tracks, use, truth), use, 0.0, 1, 0);
    const std::vector<double> noisy = TrackReprojectionErrors(sim.tracks, truth);
    const std::vector<double> exact = TrackReprojectionErrors(replica, truth);
    for (int j = 0; j < sim.tracks.num_tracks(); ++j) {
      if (!use[j]) continue;
      EXPECT_GT(noisy[j], 0.01) << "track " << j;
      EXPECT_LT(exact[j], 1e-6) << "track " << j << ", readout " << readout;
    }
    for (int i = 0; i < sim.tracks.num_frames(); ++i)
      EXPECT_EQ(replica.pixels[i].col(3), sim.tracks.pixels[i].col(3));
  }
}

// The noise the residuals show, corrected for what the adjustment fitted,
// is the tracks' noise.
// (Over these six scenes 2.3 % low; without the correction for the fitted
// parameters, 6 % low.)
TEST(ResidualNoisePx, IsTheTracksNoiseAtTheAdjustedState) {
  double mean = 0.0;
  const int seeds = 6;
  for (uint64_t seed = 1; seed <= seeds; ++seed) {
    const TrackSimulation sim = SmallBurst(seed, 0.05);
    std::vector<bool> use;
    SparseState state = RankOneStart(sim, &use);
    RunBundleAdjustment(sim.tracks, use, &state);
    mean += ResidualNoisePx(sim.tracks, use, state, {}) / seeds;
  }
  EXPECT_GT(mean, 0.048);
  EXPECT_LT(mean, 0.0515);
}

// The point of the correction: on 320x240 bursts with 0.03 px of noise
// the adjustment's f is off by a bias of a few percent (the noise's, long,
// against the priors', towards max(w, h)), and the solution less the
// measured bias is nearer the truth, on average and burst by burst (mean
// |f error| over these 12: 6.7 px before, 3.3 px after).
TEST(EstimateIntrinsicsBias, TakesTheBiasOffTheFocalLength) {
  const BundleAdjustmentOptions options;
  const BootstrapBiasOptions bootstrap;
  double estimated = 0.0, corrected = 0.0;
  const int seeds = 6;
  for (const int frames : {10, 30}) {
    for (uint64_t seed = 1; seed <= seeds; ++seed) {
      const TrackSimulation sim = SmallBurst(seed, 0.03, 0.0, frames);
      std::vector<bool> use;
      SparseState state = RankOneStart(sim, &use);
      RunBundleAdjustment(sim.tracks, use, &state, options);
      const IntrinsicsBias bias =
          EstimateIntrinsicsBias(sim.tracks, use, state, options, bootstrap);
      EXPECT_EQ(bias.replicas, bootstrap.replicas);
      const double before = std::abs(state.camera.f - sim.camera.f);
      const double after = std::abs(state.camera.f - bias.f - sim.camera.f);
      EXPECT_LT(after, before + 0.1) << frames << " frames, seed " << seed;
      estimated += before;
      corrected += after;
    }
  }
  EXPECT_LT(corrected, 0.6 * estimated) << "mean |f error| " << estimated / (2 * seeds)
                                        << " px before, " << corrected / (2 * seeds) << " px after";
}

// Replicas 2k and 2k + 1 carry one draw of noise with opposite signs, so
// their mean is the explained tracks; the next pair draws anew.
TEST(ReplicaTracks, PairsCarryOneDrawWithOppositeSigns) {
  const TrackSimulation sim = SmallBurst(2, 0.05);
  const std::vector<bool> use(sim.tracks.num_tracks(), true);
  const FeatureTracks explained = ExplainedTracks(sim.tracks, use, SimulatedState(sim, 0.0));
  const FeatureTracks first = ReplicaTracks(explained, use, 0.3, 7, 2);
  const FeatureTracks second = ReplicaTracks(explained, use, 0.3, 7, 3);
  const FeatureTracks next = ReplicaTracks(explained, use, 0.3, 7, 4);
  const int frame = sim.tracks.reference == 0 ? 1 : 0;
  const Eigen::Matrix2Xd up = first.pixels[frame] - explained.pixels[frame];
  const Eigen::Matrix2Xd down = second.pixels[frame] - explained.pixels[frame];
  EXPECT_GT(up.norm(), 0.1);
  EXPECT_LT((up + down).norm(), 1e-9 * up.norm());
  EXPECT_GT((next.pixels[frame] - first.pixels[frame]).norm(), 0.1);
}

// The replicas run on OpenCV's pool with noise of their own seeds: the
// bias does not depend on the threads.
TEST(EstimateIntrinsicsBias, IsTheSameOnOneThreadAsOnMany) {
  const TrackSimulation sim = SmallBurst(3, 0.03);
  std::vector<bool> use;
  SparseState state = RankOneStart(sim, &use);
  RunBundleAdjustment(sim.tracks, use, &state);
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const IntrinsicsBias one = EstimateIntrinsicsBias(sim.tracks, use, state, {}, {});
  cv::setNumThreads(std::max(2, threads));
  const IntrinsicsBias many = EstimateIntrinsicsBias(sim.tracks, use, state, {}, {});
  cv::setNumThreads(threads);
  EXPECT_EQ(one.f, many.f);
  EXPECT_EQ(one.k1, many.k1);
  EXPECT_EQ(one.k2, many.k2);
}

// A usable bias comes off f, k1 and k2; one not usable, or none, leaves the
// camera as it is.
TEST(Debiased, TakesAUsableBiasOffTheCameraOnly) {
  CameraModel camera = CameraModel::Initial(320, 240);
  camera.k1 = -0.1;
  camera.k2 = 0.02;
  IntrinsicsBias bias;
  bias.f = 12.0;
  bias.k1 = -0.01;
  bias.k2 = 0.005;
  bias.usable = true;
  const CameraModel debiased = Debiased(camera, bias);
  EXPECT_DOUBLE_EQ(debiased.f, camera.f - 12.0);
  EXPECT_DOUBLE_EQ(debiased.k1, -0.09);
  EXPECT_DOUBLE_EQ(debiased.k2, 0.015);
  EXPECT_EQ(debiased.cx, camera.cx);
  bias.usable = false;
  EXPECT_EQ(Debiased(camera, bias).f, camera.f);
  EXPECT_EQ(Debiased(camera, std::nullopt).f, camera.f);
}

// The bias is the mean shift over the pairs whose two replicas solved; it is
// usable only where at least half the replicas count and it stays within
// max_correction_percent of f.
TEST(MeanShift, AveragesTheSolvedPairsAndJudgesTheShift) {
  const CameraModel camera = CameraModel::Initial(320, 240);
  BootstrapBiasOptions bootstrap;
  std::vector<ReplicaEstimate> replicas(4, ReplicaEstimate{camera, 0.5, true});
  replicas[0].camera.f += 4.0;
  replicas[1].camera.f += 8.0;
  replicas[1].readout = 0.7;
  replicas[2].camera.f += 1000.0;  // failed: its pair is not counted
  replicas[2].solved = false;
  replicas[3].camera.f -= 500.0;  // solved, but its partner failed
  IntrinsicsBias bias = MeanShift(replicas, camera, 0.5, bootstrap);
  EXPECT_EQ(bias.replicas, 2);
  EXPECT_DOUBLE_EQ(bias.f, 6.0);
  EXPECT_NEAR(bias.readout, 0.1, 1e-12);
  EXPECT_TRUE(bias.usable);
  replicas[0].solved = false;  // no whole pair left
  EXPECT_FALSE(MeanShift(replicas, camera, 0.5, bootstrap).usable);
  EXPECT_EQ(MeanShift(replicas, camera, 0.5, bootstrap).replicas, 0);
  bootstrap.max_correction_percent = 1.0;  // 8 px is 2.5 % of f = 320
  EXPECT_FALSE(MeanShift({replicas[1], replicas[1]}, camera, 0.5, bootstrap).usable);
  EXPECT_TRUE(BiasMatters(0.01 * camera.f, camera.f, bootstrap));
  EXPECT_FALSE(BiasMatters(0.001 * camera.f, camera.f, bootstrap));
}

// Where the tracks' noise leaves sigma_f large enough, the bias is measured
// and usable; below the gate nothing is measured; a camera held or given as
// a prior has no self-calibration's bias to measure.
TEST(MeasureBiasIfItMatters, MeasuresWhereSigmaFIsLargeEnough) {
  const TrackSimulation sim = SmallBurst(4, 0.03);
  std::vector<bool> use;
  SparseState state = RankOneStart(sim, &use);
  RunBundleAdjustment(sim.tracks, use, &state);
  BootstrapBiasOptions bootstrap;
  const std::optional<IntrinsicsBias> bias =
      MeasureBiasIfItMatters(sim.tracks, use, state, {}, bootstrap);
  ASSERT_TRUE(bias.has_value());
  EXPECT_GT(bias->sigma_f_noise_px, 0.0);
  EXPECT_TRUE(bias->usable);
  bootstrap.min_sigma_f_percent = 100.0;
  EXPECT_FALSE(MeasureBiasIfItMatters(sim.tracks, use, state, {}, bootstrap).has_value());
  BundleAdjustmentOptions held;
  held.fix_intrinsics = true;
  EXPECT_THROW(MeasureBiasIfItMatters(sim.tracks, use, state, held, {}), std::invalid_argument);
  BundleAdjustmentOptions known;
  known.known_f_sigma_percent = 1.0;
  EXPECT_THROW(EstimateIntrinsicsBias(sim.tracks, use, state, known, {}), std::invalid_argument);
}

// What a fusion takes: the burst's own calibration less its bias -- the
// self-calibration beside a known prior where there is one, else the camera
// where the burst kept it; nothing where a fallback or a known camera
// replaced it.
TEST(SparseReconstruction, DebiasedCameraIsOfTheBurstsOwnCalibration) {
  IntrinsicsBias bias;
  bias.f = 10.0;
  bias.usable = true;
  SparseReconstruction sparse;
  sparse.state.camera = CameraModel::Initial(320, 240);
  sparse.intrinsics_bias = bias;
  ASSERT_TRUE(sparse.DebiasedCamera().has_value());
  EXPECT_DOUBLE_EQ(sparse.DebiasedCamera()->f, 310.0);
  sparse.calibration_used = CalibrationSource::kFallbackK1;
  EXPECT_FALSE(sparse.DebiasedCamera().has_value());
  sparse.calibration_used = CalibrationSource::kKnownPrior;
  EXPECT_FALSE(sparse.DebiasedCamera().has_value());
  SparseReconstruction::SelfEstimate self;
  self.camera = CameraModel::Initial(320, 240);
  self.camera.f = 400.0;
  self.bias = bias;
  sparse.self_estimate = self;
  EXPECT_DOUBLE_EQ(sparse.DebiasedCamera()->f, 390.0);
}

TEST(BootstrapBiasOptions, CheckNamesTheOptionOutOfRange) {
  BootstrapBiasOptions options;
  EXPECT_NO_THROW(options.Check());
  options.replicas = -1;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options.replicas = 3;  // an antithetic pair incomplete
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = {};
  options.max_correction_percent = 0.0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
