#include "core/dense/plane_selection.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/dense/plane_sweep.h"

namespace dfsm {
namespace {

// A 1x1 cost volume from a cost curve.
std::vector<cv::Mat> VolumeOfCurve(const std::vector<float>& curve) {
  std::vector<cv::Mat> costs;
  for (const float c : curve) costs.push_back(cv::Mat(1, 1, CV_32FC1, cv::Scalar(c)));
  return costs;
}

TEST(PlaneSelectionTest, ParabolaRecoversTheSubPlaneMinimum) {
  // Samples of (k - 5.3)^2 + 1: the parabola through the three best is exact.
  std::vector<float> curve;
  for (int k = 0; k < 12; ++k) curve.push_back(static_cast<float>((k - 5.3) * (k - 5.3) + 1.0));
  const PlaneSelection selection = SelectPlanes(VolumeOfCurve(curve));
  EXPECT_NEAR(selection.plane.at<float>(0, 0), 5.3f, 1e-4f);
  EXPECT_GT(selection.confidence.at<float>(0, 0), 0.9f);
  EXPECT_EQ(selection.at_edge.at<uchar>(0, 0), 0);
}

TEST(PlaneSelectionTest, WindowOffsetAndStrideMapBackToTheLattice) {
  std::vector<float> curve = {5.0f, 2.0f, 1.0f, 2.0f, 5.0f};  // minimum at slice 2
  const cv::Mat first(1, 1, CV_32SC1, cv::Scalar(40));
  const PlaneSelection selection = SelectPlanes(VolumeOfCurve(curve), first, 3);
  EXPECT_FLOAT_EQ(selection.plane.at<float>(0, 0), 46.0f);  // 40 + 2 * 3
}

// The winner of a curve under a SeedPrior, as a fine window selects it.
PlaneSelection SelectNearSeed(const std::vector<float>& curve, int first, int stride, float seed,
                              float weight) {
  PlaneSelection selection{cv::Mat(1, 1, CV_32FC1), cv::Mat(1, 1, CV_32FC1),
                           cv::Mat(1, 1, CV_8UC1)};
  SeedPrior prior;
  prior.seed = cv::Mat(1, 1, CV_32FC1, cv::Scalar(seed));
  prior.weight = weight;
  SelectPlanesNearSeedInto(VolumeOfCurve(curve), cv::Mat(1, 1, CV_32SC1, cv::Scalar(first)), stride,
                           prior, &selection);
  return selection;
}

TEST(PlaneSelectionTest, SeedPriorIsTheMaximumAPosterioriOfTwoQuadratics) {
  // A cost a (k - 2)^2 and a prior w (k - 4)^2 (the seed at lattice plane
  // 10 + 4 * 2 = 18): the sum is least at (a 2 + w 4) / (a + w), which the
  // parabola through the three best samples finds exactly.
  const float a = 1.0f, w = 0.5f;
  std::vector<float> curve;
  for (int k = 0; k < 7; ++k) curve.push_back(a * (k - 2.0f) * (k - 2.0f) + 3.0f);
  const PlaneSelection near_seed = SelectNearSeed(curve, 10, 2, 18.0f, w);
  EXPECT_NEAR(near_seed.plane.at<float>(0, 0), 10.0f + 2.0f * (a * 2 + w * 4) / (a + w), 1e-4f);
  // A sharp curve hardly moves, a shallow one follows the seed.
  for (float& c : curve) c *= 100.0f;
  EXPECT_NEAR(SelectNearSeed(curve, 10, 2, 18.0f, w).plane.at<float>(0, 0), 14.0f, 0.05f);
  // No weight: the plain winner.
  EXPECT_FLOAT_EQ(SelectNearSeed(curve, 10, 2, 18.0f, 0.0f).plane.at<float>(0, 0), 14.0f);
}

TEST(PlaneSelectionTest, SeedPriorLeavesTheEdgeFlagToThePhotoConsistency) {
  // The photo-consistency falls towards the window's first slice (its
  // minimum may lie beyond the window): the prior pulls the winner inside
  // (to 2.95), but the flag still says the search did not reach the minimum.
  const std::vector<float> falling = {1.0f, 1.1f, 1.2f, 1.3f, 1.4f, 1.5f, 1.6f};
  const PlaneSelection flagged = SelectNearSeed(falling, 0, 1, 3.0f, 1.0f);
  EXPECT_NEAR(flagged.plane.at<float>(0, 0), 2.95f, 1e-4f);
  EXPECT_EQ(flagged.at_edge.at<uchar>(0, 0), 255);
  // A minimum inside the window stays unflagged even where the prior pulls
  // the winner onto the window's last slice: {3 + 72, 2 + 50, 1 + 32, 2 + 18,
  // 3 + 8, 4 + 2, 5 + 0} with the seed on slice 6 and weight 2.
  const std::vector<float> inside = {3, 2, 1, 2, 3, 4, 5};
  const PlaneSelection pulled = SelectNearSeed(inside, 0, 1, 6.0f, 2.0f);
  EXPECT_FLOAT_EQ(pulled.plane.at<float>(0, 0), 6.0f);
  EXPECT_EQ(pulled.at_edge.at<uchar>(0, 0), 0);
}

TEST(PlaneSelectionTest, RivalValleyLowersTheConfidence) {
  // Two valleys of nearly equal depth (a repetitive texture): low confidence.
  const std::vector<float> ambiguous = {9, 5, 2.0f, 5, 9, 5, 2.1f, 5, 9};
  const std::vector<float> unique = {9, 8, 7, 5, 2.0f, 5, 7, 8, 9};
  const float low = SelectPlanes(VolumeOfCurve(ambiguous)).confidence.at<float>(0, 0);
  const float high = SelectPlanes(VolumeOfCurve(unique)).confidence.at<float>(0, 0);
  EXPECT_LT(low, 0.1f);
  EXPECT_GT(high, 0.7f);
}

TEST(PlaneSelectionTest, MinimumOnTheFirstSliceIsFlaggedAndNoCostGivesNoPlane) {
  const PlaneSelection edge = SelectPlanes(VolumeOfCurve({1, 2, 3, 4}));
  EXPECT_EQ(edge.at_edge.at<uchar>(0, 0), 255);
  EXPECT_FLOAT_EQ(edge.plane.at<float>(0, 0), 0.0f);
  const PlaneSelection none = SelectPlanes(VolumeOfCurve({kNoCost, kNoCost, kNoCost}));
  EXPECT_LT(none.plane.at<float>(0, 0), 0.0f);
  EXPECT_EQ(none.confidence.at<float>(0, 0), 0.0f);
}

TEST(PlaneSelectionTest, ConfidenceOfAGivenWinnerIsThatOfItsValleysMinimum) {
  const std::vector<float> curve = {9, 8, 7, 5, 2.0f, 5, 7, 8, 9};  // minimum at 4
  const float own = SelectPlanes(VolumeOfCurve(curve)).confidence.at<float>(0, 0);
  ASSERT_GT(own, 0.5f);
  const auto at = [&](float plane, int reach) {
    return ConfidenceOfPlanes(VolumeOfCurve(curve), cv::Mat(1, 1, CV_32FC1, cv::Scalar(plane)),
                              reach)
        .at<float>(0, 0);
  };
  EXPECT_FLOAT_EQ(at(4.0f, 0), own);
  EXPECT_FLOAT_EQ(at(4.3f, 0), own);  // rounded to its plane
  // On the valley's slope: the minimum it descends to, if within reach.
  EXPECT_FLOAT_EQ(at(6.0f, 2), own);
  EXPECT_FLOAT_EQ(at(6.0f, 1), 0.0f);
  EXPECT_FLOAT_EQ(at(-1.0f, 8), 0.0f);  // no winner
}

TEST(PlaneSelectionTest, AWinnerInAnotherValleyGetsThatValleysConfidence) {
  // The winner sits in the shallower of two valleys: its own minimum (6) is
  // beaten by the other (2), so the photo-consistency does not support it.
  const std::vector<float> curve = {9, 5, 2.0f, 5, 9, 5, 4.0f, 5, 9};
  const cv::Mat plane(1, 1, CV_32FC1, cv::Scalar(6.0f));
  EXPECT_FLOAT_EQ(ConfidenceOfPlanes(VolumeOfCurve(curve), plane, 1).at<float>(0, 0), 0.0f);
  const cv::Mat best(1, 1, CV_32FC1, cv::Scalar(2.0f));
  EXPECT_NEAR(ConfidenceOfPlanes(VolumeOfCurve(curve), best, 1).at<float>(0, 0), 1.0f - 2.0f / 4.0f,
              1e-6f);
}

TEST(PlaneSelectionTest, ConfidenceOfPlanesGivesTheValleysCost) {
  const std::vector<float> curve = {9, 5, 2.0f, 5, 9, 5, 4.0f, 5, 9};
  cv::Mat cost;
  ConfidenceOfPlanes(VolumeOfCurve(curve), cv::Mat(1, 1, CV_32FC1, cv::Scalar(1.0f)), 1, &cost);
  EXPECT_FLOAT_EQ(cost.at<float>(0, 0), 2.0f);  // walked down to slice 2
  ConfidenceOfPlanes(VolumeOfCurve(curve), cv::Mat(1, 1, CV_32FC1, cv::Scalar(-1.0f)), 1, &cost);
  EXPECT_FLOAT_EQ(cost.at<float>(0, 0), kNoCost);  // no winner
}

TEST(PlaneSelectionTest, CostOutliersAreJudgedAgainstPixelsOfLikeTexture) {
  // Left half flat, right half a strong checkerboard. A correct match costs
  // 1 on the flat half and 4 on the textured one; two patches cost more:
  // 5 on the flat half (an outlier there, though cheaper than every textured
  // pixel) and 10 on the textured half (2.5 x its like, within a ratio of 3).
  const int rows = 64, cols = 64;
  cv::Mat reference(rows, cols, CV_32FC1, cv::Scalar(0.5f));
  for (int y = 0; y < rows; ++y)
    for (int x = cols / 2; x < cols; ++x) reference.at<float>(y, x) = ((x / 2 + y / 2) % 2) ? 1 : 0;
  cv::Mat cost(rows, cols, CV_32FC1, cv::Scalar(1.0f));
  cost.colRange(cols / 2, cols).setTo(4.0f);
  const cv::Rect flat_patch(4, 4, 8, 8), textured_patch(44, 44, 8, 8);
  cost(flat_patch).setTo(5.0f);
  cost(textured_patch).setTo(10.0f);
  cost.at<float>(60, 60) = kNoCost;
  cv::Mat confidence(rows, cols, CV_32FC1, cv::Scalar(0.5f));

  EXPECT_EQ(RejectCostOutliers(cost, reference, 2, 3.0, &confidence), flat_patch.area());
  EXPECT_EQ(cv::countNonZero(confidence(flat_patch)), 0);
  EXPECT_EQ(cv::countNonZero(confidence), rows * cols - flat_patch.area());

  // A lower ratio takes the textured patch too, and says where.
  confidence.setTo(0.5f);
  cv::Mat rejected;
  EXPECT_EQ(RejectCostOutliers(cost, reference, 2, 2.0, &confidence, &rejected),
            flat_patch.area() + textured_patch.area());
  EXPECT_EQ(cv::countNonZero(rejected), flat_patch.area() + textured_patch.area());
  EXPECT_EQ(cv::countNonZero(rejected(textured_patch)), textured_patch.area());
}

TEST(PlaneSelectionTest, CostOutliersOfAPerfectMatchAreHeldToAFloor) {
  // Frames identical but for a patch (noise-free, or clipped white): the
  // median cost is 0, and a cost just above it is no outlier.
  const cv::Mat reference(32, 32, CV_32FC1, cv::Scalar(0.5f));
  cv::Mat cost = cv::Mat::zeros(32, 32, CV_32FC1);
  cost(cv::Rect(0, 0, 4, 4)).setTo(2.0f * kMinOutlierCostScale);
  cost(cv::Rect(20, 20, 4, 4)).setTo(4.0f * kMinOutlierCostScale);
  cv::Mat confidence(32, 32, CV_32FC1, cv::Scalar(0.5f));
  EXPECT_EQ(RejectCostOutliers(cost, reference, 2, 3.0, &confidence), 16);
  EXPECT_EQ(cv::countNonZero(confidence(cv::Rect(20, 20, 4, 4))), 0);
  EXPECT_EQ(cv::countNonZero(confidence(cv::Rect(0, 0, 4, 4))), 16);
}

}  // namespace
}  // namespace dfsm
