#include "core/dense/depth_completion.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace dfsm {
namespace {

TEST(DepthCompletionTest, FillsEveryHoleAndKeepsEveryMeasurement) {
  // Two surfaces split at x = 40 (an image edge too); a hole across the edge
  // and a large one inside the right surface.
  cv::Mat values(60, 80, CV_32FC1), guide(60, 80, CV_32FC1);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) {
      values.at<float>(y, x) = x < 40 ? 10.0f : 30.0f;
      guide.at<float>(y, x) = x < 40 ? 0.2f : 0.8f;
    }
  cv::Mat weight(values.size(), CV_32FC1, cv::Scalar(1.0f));
  weight(cv::Rect(30, 20, 20, 10)).setTo(0.0f);  // across the edge
  weight(cv::Rect(50, 5, 25, 45)).setTo(0.0f);   // inside the right surface
  const cv::Mat filled = FillHoles(values, weight, guide);
  ASSERT_EQ(filled.size(), values.size());
  cv::Mat measured_diff;
  cv::absdiff(filled, values, measured_diff);
  measured_diff.setTo(0.0f, weight <= 0.0f);
  EXPECT_EQ(cv::countNonZero(measured_diff), 0);  // measurements untouched
  // Inside the large hole: the right surface's value.
  EXPECT_NEAR(filled.at<float>(27, 62), 30.0f, 0.5f);
  // Across the edge: each side takes its own surface, following the guide.
  EXPECT_NEAR(filled.at<float>(25, 33), 10.0f, 2.0f);
  EXPECT_NEAR(filled.at<float>(25, 46), 30.0f, 2.0f);
  double lowest = 0.0, highest = 0.0;
  cv::minMaxLoc(filled, &lowest, &highest);
  EXPECT_GE(lowest, 9.5);
  EXPECT_LE(highest, 30.5);
}

TEST(DepthCompletionTest, AHoleInARegionTakesTheDepthOfItsOutline) {
  // TUM's black monitor: a dark square (guide 0.05) in a bright scene (0.8),
  // measured only along its outline (depth 2) and everywhere outside (depth 8).
  cv::Mat values(80, 80, CV_32FC1, cv::Scalar(8.0f)), guide(80, 80, CV_32FC1, cv::Scalar(0.8f));
  const cv::Rect square(20, 20, 40, 40);
  guide(square).setTo(0.05f);
  values(square).setTo(2.0f);
  cv::Mat weight(values.size(), CV_32FC1, cv::Scalar(1.0f));
  weight(cv::Rect(22, 22, 36, 36)).setTo(0.0f);  // the interior, a hole
  const cv::Mat filled = FillHoles(values, weight, guide);
  EXPECT_NEAR(filled.at<float>(40, 40), 2.0f, 0.05f);
  EXPECT_NEAR(filled.at<float>(24, 55), 2.0f, 0.05f);
  // Without the edge-aware spread the surroundings leak in.
  DepthCompletionOptions push_pull_only;
  push_pull_only.smoother.lambda = 0.0;
  EXPECT_GT(FillHoles(values, weight, guide, push_pull_only).at<float>(40, 40), 2.5f);
}

TEST(DepthCompletionTest, AHoleNoRegionReachesFallsBackToItsSurroundings) {
  // A bright square whose outline holds no measurement: the spread stops at
  // its edge, and push-pull fills it from the measurements around it.
  cv::Mat values(80, 80, CV_32FC1, cv::Scalar(8.0f)), guide(80, 80, CV_32FC1, cv::Scalar(0.1f));
  const cv::Rect square(20, 20, 40, 40);
  guide(square).setTo(0.9f);
  cv::Mat weight(values.size(), CV_32FC1, cv::Scalar(1.0f));
  weight(square).setTo(0.0f);
  values(square).setTo(0.0f);  // no value to leak
  const cv::Mat filled = FillHoles(values, weight, guide);
  EXPECT_NEAR(filled.at<float>(40, 40), 8.0f, 0.05f);
  EXPECT_NEAR(filled.at<float>(21, 21), 8.0f, 0.05f);
}

TEST(DepthCompletionTest, NothingToFillFrom) {
  const cv::Mat values(8, 8, CV_32FC1, cv::Scalar(1.0f));
  const cv::Mat zero(8, 8, CV_32FC1, cv::Scalar(0.0f));
  EXPECT_TRUE(FillHoles(values, zero, values).empty());
  DepthCompletionOptions bad;
  bad.filled_weight = 0.0f;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
