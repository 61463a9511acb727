#include "core/sparse/rank_one_init.h"

#include <gtest/gtest.h>

#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

std::vector<Eigen::Matrix3d> TrueRotations(const TrackSimulation& sim) {
  std::vector<Eigen::Matrix3d> rotations;
  for (const Pose& pose : sim.poses) rotations.push_back(pose.R);
  return rotations;
}

// Returns the scale s with estimate ≈ s * truth (least squares) and the largest
// relative deviation from it.
std::pair<double, double> ScaleFit(const std::vector<double>& estimate,
                                   const std::vector<double>& truth) {
  double num = 0.0, den = 0.0;
  for (size_t j = 0; j < truth.size(); ++j)
    num += estimate[j] * truth[j], den += truth[j] * truth[j];
  const double s = num / den;
  double worst = 0.0;
  for (size_t j = 0; j < truth.size(); ++j)
    worst = std::max(worst, std::abs(estimate[j] - s * truth[j]) / std::abs(s * truth[j]));
  return {s, worst};
}

TEST(RankOneInit, IsExactUpToScaleOnNoiseFreeTracks) {
  for (const double k1 : {0.0, -0.08}) {
    TrackSimulatorOptions options;
    options.k1 = k1;
    options.rotation_deg = 1.0;
    const TrackSimulation sim = SimulateTracks(options);
    ASSERT_GT(sim.tracks.num_tracks(), 250);
    const RankOneResult result = RankOneInit(sim.tracks, sim.camera, TrueRotations(sim));
    ASSERT_TRUE(result.ok);
    EXPECT_EQ(std::count(result.inliers.begin(), result.inliers.end(), true),
              sim.tracks.num_tracks());
    EXPECT_LT(result.rms_residual_px, 1e-6);

    const auto [scale, worst] = ScaleFit(result.inverse_depths, sim.inverse_depths);
    EXPECT_GT(scale, 0.0) << "sign not fixed: inverse depths must be positive";
    EXPECT_LT(worst, 1e-6);
    // Centres share the inverse scale: w C is what the data fix.
    for (int i = 1; i < sim.tracks.num_frames(); ++i) {
      const Eigen::Vector3d truth = sim.poses[i].Centre();
      const Eigen::Vector3d estimate = result.poses[i].Centre() * scale;
      EXPECT_LT((estimate - truth).norm(), 1e-6 * truth.norm()) << "frame " << i;
      EXPECT_LT(RotationErrorDeg(result.poses[i].R, sim.poses[i].R), 1e-9);
    }
  }
}

TEST(RankOneInit, RecoversTheForwardComponentOfMotion) {
  // Motion mostly along the optical axis: dropping C_z would be badly wrong here.
  TrackSimulatorOptions options;
  options.seed = 5;
  TrackSimulation sim = SimulateTracks(options);
  for (int i = 1; i < sim.tracks.num_frames(); ++i) {
    const Eigen::Vector3d centre(0.001 * i, 0.0005, 0.004 * i);
    sim.poses[i].T = -sim.poses[i].R * centre;
  }
  // Re-project with the forward motion.
  const FeatureTracks& old = sim.tracks;
  for (int i = 0; i < old.num_frames(); ++i) {
    for (int j = 0; j < old.num_tracks(); ++j) {
      const Eigen::Vector2d x = sim.camera.PixelToUndistorted(old.pixels[0].col(j));
      const Eigen::Vector3d X =
          sim.poses[i].Transform(Eigen::Vector3d(x.x(), x.y(), 1.0) / sim.inverse_depths[j]);
      sim.tracks.pixels[i].col(j) = *sim.camera.UndistortedToPixel(X.head<2>() / X.z());
    }
  }
  const RankOneResult result = RankOneInit(sim.tracks, sim.camera, TrueRotations(sim));
  ASSERT_TRUE(result.ok);
  const auto [scale, worst] = ScaleFit(result.inverse_depths, sim.inverse_depths);
  EXPECT_LT(worst, 1e-6);
  const Eigen::Vector3d centre = result.poses.back().Centre() * scale;
  EXPECT_NEAR(centre.z(), sim.poses.back().Centre().z(), 1e-8);
}

TEST(RankOneInit, RejectsOutlierTracks) {
  TrackSimulatorOptions options;
  options.noise_px = 0.1;
  options.seed = 3;
  TrackSimulation sim = SimulateTracks(options);
  const int m = sim.tracks.num_tracks();
  std::vector<bool> corrupted(m, false);
  for (int j = 0; j < m; j += 10) {
    corrupted[j] = true;
    for (int i = 4; i < sim.tracks.num_frames(); ++i)
      sim.tracks.pixels[i].col(j) += Eigen::Vector2d(6.0, -4.0);
  }
  const RankOneResult result = RankOneInit(sim.tracks, sim.camera, TrueRotations(sim));
  ASSERT_TRUE(result.ok);
  int caught = 0, false_alarms = 0;
  for (int j = 0; j < m; ++j) {
    if (corrupted[j] && !result.inliers[j]) ++caught;
    if (!corrupted[j] && !result.inliers[j]) ++false_alarms;
  }
  EXPECT_EQ(caught, (m + 9) / 10);
  EXPECT_LT(false_alarms, m / 50);
  std::vector<double> estimate, truth;
  for (int j = 0; j < m; ++j)
    if (result.inliers[j])
      estimate.push_back(result.inverse_depths[j]), truth.push_back(sim.inverse_depths[j]);
  const auto [scale, worst] = ScaleFit(estimate, truth);
  EXPECT_GT(scale, 0.0);
  EXPECT_LT(worst, 0.25);  // 0.1 px noise on ~10 px of parallax
}

TEST(RankOneInit, FailsCleanlyWithTooFewTracks) {
  FeatureTracks tracks;
  tracks.pixels.assign(3, Eigen::Matrix2Xd::Zero(2, 2));
  const RankOneResult result =
      RankOneInit(tracks, CameraModel::Initial(64, 48),
                  std::vector<Eigen::Matrix3d>(3, Eigen::Matrix3d::Identity()));
  EXPECT_FALSE(result.ok);
}

}  // namespace
}  // namespace dfsm
