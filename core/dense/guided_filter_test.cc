#include "core/dense/guided_filter.h"

#include <gtest/gtest.h>

namespace dfsm {
namespace {

// A vertical step in the guide at column 32, and a noisy input with the same step.
struct StepImages {
  cv::Mat guide, input;
  StepImages() : guide(64, 64, CV_32FC1), input(64, 64, CV_32FC1) {
    cv::RNG rng(7);
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        guide.at<float>(y, x) = x < 32 ? 0.2f : 0.8f;
        input.at<float>(y, x) = (x < 32 ? 1.0f : 3.0f) + static_cast<float>(rng.gaussian(0.1));
      }
  }
};

TEST(GuidedFilterTest, SmoothsNoiseButKeepsTheGuidesEdge) {
  const StepImages images;
  const cv::Mat output = GuidedFilter(images.guide, images.input, 6, 1e-3f);
  cv::Scalar mean, stddev;
  cv::meanStdDev(output(cv::Rect(5, 5, 20, 54)), mean, stddev);
  EXPECT_NEAR(mean[0], 1.0, 0.03);
  EXPECT_LT(stddev[0], 0.05);  // input noise 0.1
  // Right beside the edge the values stay on their own side.
  for (int y = 10; y < 54; ++y) {
    EXPECT_NEAR(output.at<float>(y, 31), 1.0f, 0.15f);
    EXPECT_NEAR(output.at<float>(y, 32), 3.0f, 0.15f);
  }
}

TEST(GuidedFilterTest, WeightedFormIgnoresZeroWeightOutliers) {
  StepImages images;
  cv::Mat weight(images.input.size(), CV_32FC1, cv::Scalar(1.0f));
  // Outliers with no weight inside the left region, and a hole to fill.
  for (int y = 20; y < 24; ++y)
    for (int x = 10; x < 14; ++x) {
      images.input.at<float>(y, x) = 50.0f;
      weight.at<float>(y, x) = 0.0f;
    }
  cv::Mat support;
  const cv::Mat output =
      WeightedGuidedFilter(images.guide, images.input, weight, 6, 1e-3f, &support);
  EXPECT_NEAR(output.at<float>(22, 12), 1.0f, 0.1f);
  EXPECT_NEAR(output.at<float>(40, 50), 3.0f, 0.1f);
  EXPECT_GT(support.at<float>(22, 12), 0.5f);
}

// The fast form (models fitted at half resolution) matches the exact one
// away from the edge and keeps the edge where the guide has it.
TEST(GuidedFilterTest, SubsampledFitKeepsTheEdge) {
  const StepImages images;
  const cv::Mat weight(images.input.size(), CV_32FC1, cv::Scalar(1.0f));
  const cv::Mat fast =
      WeightedGuidedFilter(images.guide, images.input, weight, 6, 1e-3f, nullptr, 2);
  for (int y = 10; y < 54; ++y) {
    EXPECT_NEAR(fast.at<float>(y, 31), 1.0f, 0.15f);
    EXPECT_NEAR(fast.at<float>(y, 32), 3.0f, 0.15f);
    EXPECT_NEAR(fast.at<float>(y, 10), 1.0f, 0.1f);
  }
}

}  // namespace
}  // namespace dfsm
