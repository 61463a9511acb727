#include "core/synth/camera_effects.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <vector>

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
// row of the reference, whose pose is the ground truth's (the identity). The
// truth's depth follows the reference's rows in the same way: each row seen
// from its own row's pose.
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
  // Median relative depth difference along a row of the reference's truth
  // (the median: where the row crosses a depth edge, a shift of a hundredth
  // of a pixel can move a pixel to the other surface).
  const auto depth_difference = [&](int row) {
    std::vector<double> relative;
    for (int x = 0; x < options.width; ++x) {
      const float a = global.truth.depth.at<float>(row, x),
                  b = rolling.truth.depth.at<float>(row, x);
      if (a > 0.0f) relative.push_back(std::abs(a - b) / a);
    }
    std::nth_element(relative.begin(), relative.begin() + relative.size() / 2, relative.end());
    return relative[relative.size() / 2];
  };
  // The middle row 0.003 frames from the identity: 4e-5; the top and bottom
  // rows 0.4 frames from it: 3e-3.
  EXPECT_LT(depth_difference(middle), 2e-4);
  EXPECT_GT(depth_difference(0), 1e-3);
  EXPECT_GT(depth_difference(options.height - 1), 1e-3);
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

// Every effect of issue 13 set to 0 explicitly renders what the default
// options render, byte for byte (frames and depth), with and without the
// older effects on.
TEST(CameraEffects, NewEffectsAtZeroRenderTheDefaultBurst) {
  for (const double readout : {0.0, 0.6}) {
    SynthOptions options = EffectsOptions();
    options.noise_sigma = 1.0;
    options.jpeg_quality = 85;
    options.supersampling = 2;
    options.effects.rolling_shutter_readout = readout;
    options.effects.vignetting = readout;
    const SynthBurst plain = SynthesizeBurst(options);
    options.effects.exposure_time = 0.0;
    options.effects.k3 = options.effects.p1 = options.effects.p2 = 0.0;
    options.effects.shot_noise_gain = 0.0;
    options.effects.bayer = false;
    options.moving_object = 0.0;
    options.curved_surfaces = 0;
    options.untextured = 0.0;
    const SynthBurst zero = SynthesizeBurst(options);
    for (int i = 0; i < 3; ++i)
      EXPECT_EQ(cv::norm(plain.frames[i], zero.frames[i], cv::NORM_INF), 0) << "frame " << i;
    EXPECT_EQ(cv::norm(plain.truth.depth, zero.truth.depth, cv::NORM_INF), 0.0);
    // Each one on changes the frames.
    for (int effect = 0; effect < 9 && readout == 0.0; ++effect) {
      SynthOptions on = options;
      switch (effect) {
        case 0:
          on.effects.exposure_time = 0.5;
          break;
        case 1:
          on.effects.k3 = 0.3;
          break;
        case 2:
          on.effects.p1 = 0.005;
          break;
        case 3:
          on.effects.p2 = 0.005;
          break;
        case 4:
          on.effects.shot_noise_gain = 4.0;
          break;
        case 5:
          on.moving_object = 0.02;
          break;
        case 6:
          on.curved_surfaces = 1;
          break;
        case 7:
          on.effects.bayer = true;
          break;
        default:
          on.untextured = 0.5;
          break;
      }
      const SynthBurst changed = SynthesizeBurst(on);
      EXPECT_GT(cv::norm(plain.frames[1], changed.frames[1], cv::NORM_L1), 0.0)
          << "effect " << effect << " readout " << readout;
    }
  }
}

// Poisson statistics: mean L, variance L / gain, in both of the sampler's
// regimes (Knuth's below 64 electrons, Gaussian above).
TEST(CameraEffects, ShotNoiseHasPoissonStatistics) {
  for (const double gain : {0.5, 4.0}) {
    for (const double level : {10.0, 100.0}) {
      cv::Mat image(200, 200, CV_32FC3, cv::Scalar::all(level));
      AddShotNoise(gain, 1, 7, &image);
      cv::Scalar mean, stddev;
      cv::meanStdDev(image.reshape(1), mean, stddev);
      EXPECT_NEAR(mean[0], level, 0.02 * level) << "gain " << gain << " level " << level;
      EXPECT_NEAR(stddev[0] * stddev[0], level / gain, 0.05 * level / gain)
          << "gain " << gain << " level " << level;
    }
  }
  cv::Mat a(50, 50, CV_32FC1, cv::Scalar(30.0)), b = a.clone(), c = a.clone();
  AddShotNoise(2.0, 1, 7, &a);
  AddShotNoise(2.0, 1, 7, &b);
  AddShotNoise(2.0, 2, 7, &c);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);  // deterministic per (seed, frame)
  EXPECT_GT(cv::norm(a, c, cv::NORM_INF), 0.0);
}

// In a rendered burst the noise grows with brightness: darker pixels vary less.
TEST(CameraEffects, ShotNoiseVarianceGrowsWithBrightness) {
  SynthOptions options = EffectsOptions();
  options.width = 320;
  options.height = 240;
  const SynthBurst clean = SynthesizeBurst(options);
  options.effects.shot_noise_gain = 2.0;
  const SynthBurst noisy = SynthesizeBurst(options);
  // Variance of noisy - clean per brightness band of the clean frame.
  double sum[2] = {0, 0}, sum2[2] = {0, 0}, level[2] = {0, 0};
  int count[2] = {0, 0};
  const cv::Mat c = clean.frames[1].reshape(1), n = noisy.frames[1].reshape(1);
  for (int v = 0; v < c.rows; ++v)
    for (int u = 0; u < c.cols; ++u) {
      const int value = c.at<uchar>(v, u);
      const int band = value >= 20 && value < 60 ? 0 : value >= 150 && value < 210 ? 1 : -1;
      if (band < 0) continue;
      const double d = n.at<uchar>(v, u) - value;
      sum[band] += d;
      sum2[band] += d * d;
      level[band] += value;
      ++count[band];
    }
  double variance[2];
  for (int band = 0; band < 2; ++band) {
    ASSERT_GT(count[band], 1000) << "band " << band;
    const double mean = sum[band] / count[band];
    variance[band] = sum2[band] / count[band] - mean * mean;
    EXPECT_LT(std::abs(mean), 0.5) << "band " << band;
    // L / gain, plus the two 8-bit roundings (1/12 each).
    EXPECT_NEAR(variance[band], level[band] / count[band] / 2.0 + 1.0 / 6.0,
                0.15 * level[band] / count[band] / 2.0)
        << "band " << band;
  }
  EXPECT_GT(variance[1], 2.5 * variance[0]);
}

// The mosaic keeps one colour per photosite, in the pattern Demosaic reads,
// and the demosaicing gives a flat colour back.
TEST(CameraEffects, BayerMosaicRoundTripsAFlatColour) {
  const cv::Vec3f colour(40.0f, 120.0f, 200.0f);  // B, G, R
  const cv::Mat radiance(32, 48, CV_32FC3, cv::Scalar(colour[0], colour[1], colour[2]));
  const cv::Mat mosaic = BayerMosaic(radiance);
  ASSERT_EQ(mosaic.type(), CV_32FC1);
  EXPECT_EQ(mosaic.at<float>(0, 0), colour[0]);
  EXPECT_EQ(mosaic.at<float>(0, 1), colour[1]);
  EXPECT_EQ(mosaic.at<float>(1, 0), colour[1]);
  EXPECT_EQ(mosaic.at<float>(1, 1), colour[2]);
  cv::Mat mosaic8;
  mosaic.convertTo(mosaic8, CV_8UC1);
  const cv::Mat bgr = Demosaic(mosaic8);
  ASSERT_EQ(bgr.type(), CV_8UC3);
  // Away from the border, which the interpolation handles on its own.
  const cv::Mat inner = bgr(cv::Rect(2, 2, bgr.cols - 4, bgr.rows - 4));
  const cv::Scalar mean = cv::mean(inner);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(mean[c], colour[c], 0.5) << "channel " << c;
    double lowest, highest;
    cv::Mat channel;
    cv::extractChannel(inner, channel, c);
    cv::minMaxLoc(channel, &lowest, &highest);
    EXPECT_LE(highest - lowest, 1.0) << "channel " << c;
  }
}

// Through a colour filter array the noise of neighbouring pixels is
// correlated (each is interpolated from shared photosites); without one it
// is not. The noise is the difference from the same burst rendered without it.
TEST(CameraEffects, BayerNoiseIsCorrelatedBetweenNeighbours) {
  const auto neighbour_correlation = [](bool bayer) {
    SynthOptions options = EffectsOptions();
    options.noise_sigma = 4.0;
    options.effects.bayer = bayer;
    const SynthBurst noisy = SynthesizeBurst(options);
    options.noise_sigma = 0.0;
    const SynthBurst clean = SynthesizeBurst(options);
    cv::Mat a, b;
    noisy.frames[1].convertTo(a, CV_32FC3);
    clean.frames[1].convertTo(b, CV_32FC3);
    cv::Mat noise;
    cv::extractChannel(a - b, noise, 2);  // red: one photosite in four
    double sum_ab = 0.0, sum_aa = 0.0;
    for (int y = 2; y < noise.rows - 2; ++y)
      for (int x = 2; x < noise.cols - 3; ++x) {
        sum_ab += noise.at<float>(y, x) * noise.at<float>(y, x + 1);
        sum_aa += noise.at<float>(y, x) * noise.at<float>(y, x);
      }
    return sum_ab / sum_aa;
  };
  EXPECT_LT(std::abs(neighbour_correlation(false)), 0.1);
  EXPECT_GT(neighbour_correlation(true), 0.4);
  // A grey burst is a monochrome sensor: no mosaic to ask for.
  SynthOptions grey = EffectsOptions();
  grey.color = false;
  grey.effects.bayer = true;
  EXPECT_THROW(SynthesizeBurst(grey), std::invalid_argument);
}

TEST(CameraEffects, PresetsCarryTheNewEffects) {
  for (const char* name : {"webcam", "phone"}) {
    const CameraEffects effects = CameraEffects::Preset(name);
    EXPECT_NO_THROW(effects.Check());
    EXPECT_GT(effects.exposure_time, 0.0) << name;
    EXPECT_NE(effects.k3, 0.0) << name;
    EXPECT_NE(effects.p1, 0.0) << name;
    EXPECT_GT(effects.shot_noise_gain, 0.0) << name;
  }
  EXPECT_FALSE(CameraEffects::Preset("ideal").any());
  EXPECT_EQ(CameraEffects::PresetJpegQuality("ideal"), 0);
  EXPECT_EQ(CameraEffects::PresetJpegQuality("webcam"), 80);
  EXPECT_EQ(CameraEffects::PresetJpegQuality("phone"), 90);
  EXPECT_THROW(CameraEffects::PresetJpegQuality("dslr"), std::invalid_argument);
  // Bad values are refused by name.
  const auto message = [](const CameraEffects& effects) {
    try {
      effects.Check();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  CameraEffects bad;
  bad.exposure_time = 1.5;
  EXPECT_NE(message(bad).find("exposure_time"), std::string::npos);
  bad = CameraEffects();
  bad.p2 = 0.1;
  EXPECT_NE(message(bad).find("p2"), std::string::npos);
  bad = CameraEffects();
  bad.shot_noise_gain = 0.01;
  EXPECT_NE(message(bad).find("shot_noise_gain"), std::string::npos);
  bad = CameraEffects();
  bad.k3 = std::nan("");
  EXPECT_NE(message(bad).find("k3"), std::string::npos);
}

}  // namespace
}  // namespace dfsm
