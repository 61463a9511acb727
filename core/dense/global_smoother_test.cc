#include "core/dense/global_smoother.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dfsm {
namespace {

// Spreads value 5 from column 10 and value 9 from column 50 of a 40 x 60
// image (normalized: smoothed value x weight over smoothed weight) and
// returns the result.
cv::Mat SpreadTwoColumns(const cv::Mat& guide, const GlobalSmootherOptions& options) {
  cv::Mat value = cv::Mat::zeros(guide.size(), CV_32FC1);
  cv::Mat weight = cv::Mat::zeros(guide.size(), CV_32FC1);
  value.col(10).setTo(5.0f);
  value.col(50).setTo(9.0f);
  weight.col(10).setTo(1.0f);
  weight.col(50).setTo(1.0f);
  value = value.mul(weight);
  SmoothAlongEdges(guide, {&value, &weight}, options);
  cv::Mat spread;
  cv::divide(value, weight, spread);
  return spread;
}

TEST(GlobalSmootherTest, KeepsAConstantImage) {
  cv::Mat guide(30, 40, CV_32FC1);
  cv::randu(guide, 0.0f, 255.0f);
  cv::Mat image(guide.size(), CV_32FC1, cv::Scalar(3.0f));
  SmoothAlongEdges(guide, {&image}, {});
  double lowest = 0.0, highest = 0.0;
  cv::minMaxLoc(image, &lowest, &highest);
  EXPECT_NEAR(lowest, 3.0, 1e-3);  // float elimination over 40-pixel chains
  EXPECT_NEAR(highest, 3.0, 1e-3);
}

TEST(GlobalSmootherTest, ASpreadStopsAtAnEdgeOfTheGuide) {
  // Two regions of even brightness split at x = 30: each takes the value
  // measured inside it, right up to the edge.
  cv::Mat guide(40, 60, CV_32FC1, cv::Scalar(40.0f));
  guide.colRange(30, 60).setTo(200.0f);
  const cv::Mat spread = SpreadTwoColumns(guide, {});
  EXPECT_NEAR(spread.at<float>(20, 0), 5.0f, 1e-3f);
  EXPECT_NEAR(spread.at<float>(20, 29), 5.0f, 1e-3f);
  EXPECT_NEAR(spread.at<float>(20, 30), 9.0f, 1e-3f);
  EXPECT_NEAR(spread.at<float>(20, 59), 9.0f, 1e-3f);
}

TEST(GlobalSmootherTest, WithoutAnEdgeTheValuesBlend) {
  const cv::Mat guide(40, 60, CV_32FC1, cv::Scalar(100.0f));
  const cv::Mat spread = SpreadTwoColumns(guide, {});
  EXPECT_GT(spread.at<float>(20, 30), 5.5f);
  EXPECT_LT(spread.at<float>(20, 30), 8.5f);
}

TEST(GlobalSmootherTest, AColourGuideStopsTheSpreadAtAnyChannelsEdge) {
  // Two colours of one brightness split at x = 30: the largest channel
  // difference (123 levels) stops the spread where the grey one could not.
  cv::Mat guide(40, 60, CV_8UC3, cv::Scalar(30, 140, 225));
  guide.colRange(30, 60).setTo(cv::Scalar(153, 153, 153));
  const cv::Mat spread = SpreadTwoColumns(guide, {});
  EXPECT_NEAR(spread.at<float>(20, 29), 5.0f, 1e-3f);
  EXPECT_NEAR(spread.at<float>(20, 30), 9.0f, 1e-3f);
}

TEST(GlobalSmootherTest, AColourGuideReadsColorSigma) {
  // The same edge with a colour sigma far above its 123 levels: the values
  // blend, whatever the grey sigma.
  cv::Mat guide(40, 60, CV_8UC3, cv::Scalar(30, 140, 225));
  guide.colRange(30, 60).setTo(cv::Scalar(153, 153, 153));
  GlobalSmootherOptions options;
  options.sigma = 0.01;
  options.color_sigma = 1000.0;
  const cv::Mat spread = SpreadTwoColumns(guide, options);
  EXPECT_GT(spread.at<float>(20, 30), 5.5f);
  EXPECT_LT(spread.at<float>(20, 30), 8.5f);
}

TEST(GlobalSmootherTest, OneRowSolvesItsTridiagonalSystem) {
  // One row, one pass: (1 + a(x-1) + a(x)) u(x) - a(x-1) u(x-1) - a(x) u(x+1)
  // = f(x), a(x) = lambda_0 exp(-|g(x+1) - g(x)| / sigma), lambda_0 = lambda / 2
  // (the schedule of one iteration). 37 columns: not a multiple of the lanes.
  GlobalSmootherOptions options;
  options.iterations = 1;
  options.lambda = 50.0;
  cv::Mat guide(1, 37, CV_32FC1), f(1, 37, CV_32FC1);
  cv::randu(guide, 0.0f, 8.0f);
  cv::randu(f, 0.0f, 10.0f);
  cv::Mat u = f.clone();
  SmoothAlongEdges(guide, {&u}, options);
  auto a = [&](int x) {
    if (x < 0 || x + 1 >= guide.cols) return 0.0;
    return options.lambda / 2.0 *
           std::exp(-std::abs(guide.at<float>(0, x + 1) - guide.at<float>(0, x)) / options.sigma);
  };
  for (int x = 0; x < guide.cols; ++x) {
    double lhs = (1.0 + a(x - 1) + a(x)) * u.at<float>(0, x);
    if (x > 0) lhs -= a(x - 1) * u.at<float>(0, x - 1);
    if (x + 1 < guide.cols) lhs -= a(x) * u.at<float>(0, x + 1);
    EXPECT_NEAR(lhs, f.at<float>(0, x), 1e-3) << "x " << x;
  }
}

TEST(GlobalSmootherTest, EveryRowIsSolvedAsIfItWereAlone) {
  // The row pass solves rows eight at a time, interleaved: each of 13 rows (one
  // whole group and a partial one) of 37 columns must come out as it does
  // alone. Odd rows of the guide are 200 levels brighter, so no value crosses
  // between rows (a pull of exp(-100)) and the columns pass changes nothing.
  cv::Mat guide(13, 37, CV_8UC1), image(13, 37, CV_32FC1);
  cv::randu(guide, 0, 12);
  for (int y = 1; y < guide.rows; y += 2) guide.row(y) += 200;
  cv::randu(image, 0.0f, 10.0f);
  const cv::Mat original = image.clone();
  SmoothAlongEdges(guide, {&image}, {});
  for (int y = 0; y < image.rows; ++y) {
    cv::Mat lone = original.row(y).clone();
    SmoothAlongEdges(guide.row(y).clone(), {&lone}, {});
    for (int x = 0; x < image.cols; ++x)
      EXPECT_NEAR(image.at<float>(y, x), lone.at<float>(0, x), 1e-6) << "row " << y << ", x " << x;
  }
}

TEST(GlobalSmootherTest, RefusesOptionsOutOfRange) {
  GlobalSmootherOptions options;
  options.sigma = 0.0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = {};
  options.color_sigma = 0.0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = {};
  options.iterations = 0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
