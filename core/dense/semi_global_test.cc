#include "core/dense/semi_global.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "core/dense/plane_selection.h"
#include "core/dense/plane_sweep.h"

namespace dfsm {
namespace {

constexpr int kPlanes = 16;
// What an unseen plane costs along a path: the sweep's default truncation.
constexpr float kMissingCost = 10.0f;

// A cost volume of `size` whose every pixel has the curve |k - best(x, y)|
// (a clear V), except where `flat` is set: there every plane costs the same
// (no texture).
std::vector<cv::Mat> Volume(const cv::Mat& best, const cv::Mat& flat) {
  std::vector<cv::Mat> costs(kPlanes);
  for (int k = 0; k < kPlanes; ++k) {
    costs[k].create(best.size(), CV_32FC1);
    for (int y = 0; y < best.rows; ++y)
      for (int x = 0; x < best.cols; ++x)
        costs[k].at<float>(y, x) =
            flat.at<uchar>(y, x) ? 3.0f : std::min(6.0f, 1.0f + std::abs(k - best.at<int>(y, x)));
  }
  return costs;
}

TEST(SemiGlobalTest, AFlatRegionTakesTheDepthOfItsSurroundings) {
  const cv::Mat best(40, 40, CV_32SC1, cv::Scalar(9));
  cv::Mat flat = cv::Mat::zeros(best.size(), CV_8UC1);
  flat(cv::Rect(10, 10, 20, 20)).setTo(255);
  const std::vector<cv::Mat> costs = Volume(best, flat);
  const cv::Mat guide(best.size(), CV_32FC1, cv::Scalar(100.0f));
  // Alone, the flat pixels have no minimum: the first plane wins the tie.
  EXPECT_FLOAT_EQ(SelectPlanes(costs).plane.at<float>(20, 20), 0.0f);
  const PlaneSelection selection = SelectSemiGlobal(costs, guide, kMissingCost, {});
  for (int y = 0; y < best.rows; ++y)
    for (int x = 0; x < best.cols; ++x)
      ASSERT_NEAR(selection.plane.at<float>(y, x), 9.0f, 0.5f) << "at " << x << ", " << y;
  // Its own curve still does not support it.
  EXPECT_FLOAT_EQ(ConfidenceOfPlanes(costs, selection.plane, 2).at<float>(20, 20), 0.0f);
  EXPECT_GT(ConfidenceOfPlanes(costs, selection.plane, 2).at<float>(2, 2), 0.5f);
}

TEST(SemiGlobalTest, ADepthEdgeAtAnImageEdgeStays) {
  // Left half at plane 3, right half at 12, with the guide's edge between.
  cv::Mat best(30, 40, CV_32SC1, cv::Scalar(3));
  best.colRange(20, 40).setTo(12);
  cv::Mat guide(best.size(), CV_32FC1, cv::Scalar(60.0f));
  guide.colRange(20, 40).setTo(180.0f);
  const std::vector<cv::Mat> costs = Volume(best, cv::Mat::zeros(best.size(), CV_8UC1));
  const PlaneSelection selection = SelectSemiGlobal(costs, guide, kMissingCost, {});
  for (int y = 0; y < best.rows; ++y) {
    EXPECT_NEAR(selection.plane.at<float>(y, 19), 3.0f, 0.5f);
    EXPECT_NEAR(selection.plane.at<float>(y, 20), 12.0f, 0.5f);
  }
}

TEST(SemiGlobalTest, AnIsolatedOutlierFollowsItsNeighbours) {
  // One pixel prefers plane 14 by a small margin over a surface at plane 5.
  const cv::Mat best(21, 21, CV_32SC1, cv::Scalar(5));
  std::vector<cv::Mat> costs = Volume(best, cv::Mat::zeros(best.size(), CV_8UC1));
  for (int k = 0; k < kPlanes; ++k) costs[k].at<float>(10, 10) = k == 14 ? 1.0f : 1.5f;
  const cv::Mat guide(best.size(), CV_32FC1, cv::Scalar(100.0f));
  EXPECT_FLOAT_EQ(SelectPlanes(costs).plane.at<float>(10, 10), 14.0f);
  EXPECT_NEAR(SelectSemiGlobal(costs, guide, kMissingCost, {}).plane.at<float>(10, 10), 5.0f, 0.5f);
}

TEST(SemiGlobalTest, UnseenPlanesStayUnseen) {
  const cv::Mat best(12, 12, CV_32SC1, cv::Scalar(4));
  std::vector<cv::Mat> costs = Volume(best, cv::Mat::zeros(best.size(), CV_8UC1));
  for (int k = 0; k < kPlanes; ++k) costs[k].at<float>(6, 6) = kNoCost;  // no frame saw it
  costs[4].at<float>(2, 2) = kNoCost;                                    // one plane unseen
  const cv::Mat guide(best.size(), CV_32FC1, cv::Scalar(100.0f));
  const PlaneSelection selection = SelectSemiGlobal(costs, guide, kMissingCost, {});
  EXPECT_FLOAT_EQ(selection.plane.at<float>(6, 6), -1.0f);
  EXPECT_NE(selection.plane.at<float>(2, 2), 4.0f);
  EXPECT_NEAR(selection.plane.at<float>(5, 5), 4.0f, 0.5f);
}

TEST(SemiGlobalTest, OptionsOutOfRangeAreNamed) {
  SemiGlobalOptions options;
  EXPECT_NO_THROW(options.Check());
  options.small_step_penalty = -1.0f;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = {};
  options.large_step_penalty = options.small_step_penalty / 2;
  try {
    options.Check();
    FAIL() << "P2 < P1 accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("large_step_penalty"), std::string::npos);
  }
}

}  // namespace
}  // namespace dfsm
