#include "core/synth/camera_effects.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <opencv2/core.hpp>
#include <stdexcept>

#include "core/synth/burst_synthesizer.h"

namespace dfsm {
namespace {

SynthOptions EffectsOptions() {
  SynthOptions options;
  options.width = 160;
  options.height = 120;
  options.frames = 3;
  options.noise_sigma = 0.0;
  options.supersampling = 1;
  options.rotation_deg = 2.0;
  return options;
}

// Every effect off renders exactly what the generator rendered before.
TEST(CameraEffects, OffIsTheIdealCamera) {
  SynthOptions options = EffectsOptions();
  const SynthBurst plain = SynthesizeBurst(options);
  options.effects = CameraEffects::Preset("ideal");
  const SynthBurst ideal = SynthesizeBurst(options);
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(cv::norm(plain.frames[i], ideal.frames[i], cv::NORM_INF), 0);
}

// A rolling shutter changes the moving frames row by row but not the middle
// row of the reference, whose pose is the ground truth's (the identity).
TEST(CameraEffects, RollingShutterMovesRowsAwayFromTheMiddle) {
  SynthOptions options = EffectsOptions();
  options.supersampling = 3;  // nearest texels alias at one sample per pixel
  const SynthBurst global = SynthesizeBurst(options);
  options.effects.rolling_shutter_readout = 0.8;
  const SynthBurst rolling = SynthesizeBurst(options);
  const int middle = options.height / 2;
  // Mean absolute difference per pixel and channel along a row.
  const auto row_difference = [&](int frame, int row) {
    return cv::norm(global.frames[frame].row(row), rolling.frames[frame].row(row), cv::NORM_L1) /
           (3.0 * options.width);
  };
  EXPECT_LT(row_difference(0, middle), 1.0);  // 0.003 frames from the pose of the truth
  EXPECT_GT(row_difference(2, 0), 3.0 * row_difference(0, middle) + 1.0);
  EXPECT_EQ(cv::norm(global.truth.depth, rolling.truth.depth, cv::NORM_INF), 0.0);
}

TEST(CameraEffects, ExposureWhiteBalanceAndVignettingScaleTheImage) {
  SynthOptions options = EffectsOptions();
  const SynthBurst plain = SynthesizeBurst(options);
  options.effects.vignetting = 0.5;
  const SynthBurst vignetted = SynthesizeBurst(options);
  // The corner is darker by about half, the centre unchanged.
  const cv::Vec3b c0 = plain.frames[0].at<cv::Vec3b>(1, 1),
                  c1 = vignetted.frames[0].at<cv::Vec3b>(1, 1);
  EXPECT_LT(c1[1], 0.6 * c0[1] + 2);
  EXPECT_LE(
      cv::norm(plain.frames[0].at<cv::Vec3b>(60, 80), vignetted.frames[0].at<cv::Vec3b>(60, 80)),
      2.0);
  options.effects = CameraEffects();
  options.effects.exposure_drift = 0.2;
  const SynthBurst drifting = SynthesizeBurst(options);
  EXPECT_EQ(cv::norm(plain.frames[0], drifting.frames[0], cv::NORM_INF), 0.0);  // reference kept
  const double ratio = cv::mean(drifting.frames[1])[1] / cv::mean(plain.frames[1])[1];
  EXPECT_NE(ratio, 1.0);
  EXPECT_NEAR(ratio, 1.0, 0.21);
}

TEST(CameraEffects, PresetsAndChecksNameTheProblem) {
  EXPECT_EQ(CameraEffects::Preset("phone").rolling_shutter_readout, 0.6);
  EXPECT_THROW(CameraEffects::Preset("dslr"), std::invalid_argument);
  CameraEffects bad;
  bad.rolling_shutter_readout = 2.0;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
}

// The pose between frames: half-way in centre and rotation.
TEST(CameraEffects, PoseAtTimeInterpolatesAndExtrapolates) {
  std::vector<Pose> path(2);
  path[1].R = Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY()).toRotationMatrix();
  path[1].T = -path[1].R * Eigen::Vector3d(0.01, 0.0, 0.0);
  const Pose half = PoseAtTime(path, 0.5);
  EXPECT_NEAR(RotationErrorDeg(half.R, Eigen::Matrix3d::Identity()), 0.01 * 180.0 / M_PI, 1e-9);
  EXPECT_NEAR((half.Centre() - Eigen::Vector3d(0.005, 0.0, 0.0)).norm(), 0.0, 1e-12);
  const Pose before = PoseAtTime(path, -0.5);
  EXPECT_NEAR((before.Centre() - Eigen::Vector3d(-0.005, 0.0, 0.0)).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace dfsm
