#include "core/dense/high_pass.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace dfsm {
namespace {

cv::Mat Texture() {
  cv::Mat texture(240, 320, CV_8UC1);
  cv::RNG rng(3);
  rng.fill(texture, cv::RNG::UNIFORM, 60, 140);
  cv::GaussianBlur(texture, texture, cv::Size(), 1.0);
  return texture;
}

TEST(HighPass, RemovesASmoothBrightnessChangeAndKeepsTheTexture) {
  const cv::Mat texture = Texture();
  // A smooth gain across the image, as vignetting or a colour-dependent white
  // balance change makes it: 0.85 at the left edge to 1.15 at the right.
  cv::Mat gain(texture.size(), CV_32F);
  for (int x = 0; x < gain.cols; ++x) gain.col(x).setTo(0.85 + 0.3 * x / (gain.cols - 1.0));
  cv::Mat as_float, changed;
  texture.convertTo(as_float, CV_32F);
  cv::multiply(as_float, gain, as_float);
  as_float.convertTo(changed, CV_8U);
  const cv::Rect inside(24, 24, texture.cols - 48, texture.rows - 48);
  const double before = cv::norm(texture(inside), changed(inside), cv::NORM_L1) / inside.area();
  const double sigma = HighPassSigma(0.0, texture.cols, texture.rows);
  const cv::Mat a = HighPass(texture, sigma), b = HighPass(changed, sigma);
  const double after = cv::norm(a(inside), b(inside), cv::NORM_L1) / inside.area();
  EXPECT_GT(before, 5.0);  // grey levels per pixel
  EXPECT_LT(after, 0.2 * before);
  // The texture itself stays: its spread around mid-grey is most of the input's.
  cv::Scalar mean, spread, input_spread;
  cv::meanStdDev(a(inside), mean, spread);
  cv::meanStdDev(texture(inside), cv::noArray(), input_spread);
  EXPECT_NEAR(mean[0], 128.0, 1.0);
  EXPECT_GT(spread[0], 0.8 * input_spread[0]);
}

TEST(HighPass, SigmaIsGivenOrAFractionOfTheLongerSideOrNone) {
  EXPECT_DOUBLE_EQ(HighPassSigma(0.0, 640, 480), 8.0);
  EXPECT_DOUBLE_EQ(HighPassSigma(0.0, 1080, 1920), 24.0);
  EXPECT_DOUBLE_EQ(HighPassSigma(5.0, 640, 480), 5.0);
  EXPECT_DOUBLE_EQ(HighPassSigma(-1.0, 640, 480), 0.0);
}

TEST(HighPass, AFlatFrameBecomesMidGrey) {
  const cv::Mat flat(48, 64, CV_8UC1, cv::Scalar(201));
  const cv::Mat high = HighPass(flat, 8.0);
  double lowest = 0, highest = 0;
  cv::minMaxLoc(high, &lowest, &highest);
  EXPECT_EQ(lowest, 128.0);
  EXPECT_EQ(highest, 128.0);
}

}  // namespace
}  // namespace dfsm
