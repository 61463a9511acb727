#include "core/pipeline/evaluation.h"

#include <gtest/gtest.h>

namespace dfsm {
namespace {

TEST(EvaluateDepthTest, ScoresAfterTheMedianScaleOrAGivenOne) {
  // The truth is twice the estimate everywhere but in one column, where the
  // estimate is 25 % too far (a wrong region).
  const cv::Mat truth(10, 10, CV_32FC1, cv::Scalar(2.0f));
  cv::Mat depth(10, 10, CV_32FC1, cv::Scalar(1.0f));
  depth.col(9).setTo(1.25f);
  const DepthEvaluation whole = EvaluateDepth(depth, truth, cv::Mat());
  EXPECT_FLOAT_EQ(whole.scale, 2.0f);
  EXPECT_NEAR(whole.abs_rel, 0.1 * 0.25, 1e-6);
  EXPECT_DOUBLE_EQ(whole.coverage, 1.0);

  // The wrong column alone: with a scale of its own it would look perfect;
  // with the whole map's it keeps its 25 %.
  cv::Mat column = cv::Mat::zeros(depth.size(), CV_8UC1);
  column.col(9).setTo(255);
  EXPECT_NEAR(EvaluateDepth(depth, truth, column).abs_rel, 0.0, 1e-9);
  const DepthEvaluation subset = EvaluateDepth(depth, truth, column, whole.scale);
  EXPECT_FLOAT_EQ(subset.scale, 2.0f);
  EXPECT_NEAR(subset.abs_rel, 0.25, 1e-6);
  EXPECT_EQ(subset.evaluated_pixels, 10);
}

TEST(EvaluateDepthTest, PixelsWithoutAnEstimateCountAgainstCoverageOnly) {
  const cv::Mat truth(4, 5, CV_32FC1, cv::Scalar(3.0f));
  cv::Mat depth(4, 5, CV_32FC1, cv::Scalar(3.0f));
  depth.row(0).setTo(0.0f);  // no estimate
  const DepthEvaluation evaluation = EvaluateDepth(depth, truth, cv::Mat());
  EXPECT_DOUBLE_EQ(evaluation.coverage, 0.75);
  EXPECT_DOUBLE_EQ(evaluation.abs_rel, 0.0);
  EXPECT_EQ(evaluation.evaluated_pixels, 15);
}

}  // namespace
}  // namespace dfsm
