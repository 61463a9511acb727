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

// A map right but for an offset in inverse depth (the small-motion ambiguity
// bends the relief so): the one-scale AbsRel sees an error, the fit finds the
// offset and nothing left after it; a map right but for its scale has no
// offset.
TEST(EvaluateDepthTest, FindsTheReliefsInverseDepthOffset) {
  cv::Mat truth(20, 30, CV_32FC1);
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u) truth.at<float>(v, u) = 1.0f + 0.1f * u;  // 1 to 3.9 m
  // w* = a w + b with a = 2 (the map at half the scale) and b = 0.1 per metre.
  constexpr double a = 2.0, b = 0.1;
  cv::Mat offset(truth.size(), CV_32FC1), scaled(truth.size(), CV_32FC1);
  double sum_w = 0.0;
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u) {
      const double w = (1.0 / truth.at<float>(v, u) - b) / a;
      offset.at<float>(v, u) = static_cast<float>(1.0 / w);
      scaled.at<float>(v, u) = 3.0f * truth.at<float>(v, u);
      sum_w += w;
    }
  const DepthEvaluation bent = EvaluateDepth(offset, truth, cv::Mat());
  EXPECT_GT(bent.abs_rel, 0.05);
  EXPECT_NEAR(bent.inverse_depth_offset, b / (a * sum_w / truth.total()), 1e-5);
  EXPECT_LT(bent.abs_rel_after_offset, 1e-5);

  const DepthEvaluation right = EvaluateDepth(scaled, truth, cv::Mat());
  EXPECT_NEAR(right.abs_rel, 0.0, 1e-6);
  EXPECT_NEAR(right.inverse_depth_offset, 0.0, 1e-6);
  EXPECT_NEAR(right.abs_rel_after_offset, 0.0, 1e-6);

  // One depth everywhere (the constant baseline): nothing to fit an offset
  // to; the figure after it is the AbsRel itself.
  const cv::Mat constant(truth.size(), CV_32FC1, cv::Scalar(2.0f));
  const DepthEvaluation flat = EvaluateDepth(constant, truth, cv::Mat());
  EXPECT_DOUBLE_EQ(flat.inverse_depth_offset, 0.0);
  EXPECT_DOUBLE_EQ(flat.abs_rel_after_offset, flat.abs_rel);
}

}  // namespace
}  // namespace dfsm
