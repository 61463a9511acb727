#include "core/dense/depth_discontinuity.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace dfsm {
namespace {

SpanBound Bound(float max_span, float min_relative_span, float zero_plane) {
  SpanBound bound;
  bound.max_span = max_span;
  bound.min_relative_span = min_relative_span;
  bound.zero_plane = zero_plane;
  return bound;
}

// Plane 10 left of column 20, plane 30 from it on.
cv::Mat Step(cv::Size size = {40, 24}) {
  cv::Mat plane(size, CV_32FC1, cv::Scalar(10.0f));
  plane.colRange(20, size.width).setTo(30.0f);
  return plane;
}

// The median is taken in bands of rows: where every pixel departs from it
// (max_departure below 0), the result is OpenCV's 5x5 median of the whole
// frame, bit for bit, at sizes with a partial last band and a band of 1 row.
TEST(KeepEdgesOfRawWinners, TheMedianInBandsIsTheMedianOfTheWholeFrame) {
  for (const cv::Size size : {cv::Size(1920, 1080), cv::Size(67, 129), cv::Size(31, 65)}) {
    cv::Mat raw(size, CV_32FC1);
    cv::randu(raw, 0.0f, 128.0f);
    const cv::Mat weight(size, CV_32FC1, cv::Scalar(1.0f));
    cv::Mat expected;
    cv::medianBlur(raw, expected, 5);
    cv::Mat refined = raw.clone();
    KeepEdgesOfRawWinners(raw, weight, -1.0f, 0, {}, refined);
    EXPECT_EQ(cv::countNonZero(refined != expected), 0) << size;
  }
}

TEST(KeepEdgesOfRawWinners, UndoesSmoothingAcrossAnEdgeAndKeepsItElsewhere) {
  const cv::Mat raw = Step();
  const cv::Mat weight(raw.size(), CV_32FC1, cv::Scalar(1.0f));
  // What a filter that does not see the edge makes of it: a ramp 9 columns
  // wide, plus a small offset everywhere that must survive.
  cv::Mat refined;
  cv::blur(raw, refined, cv::Size(9, 1), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  refined += 0.5f;
  KeepEdgesOfRawWinners(raw, weight, 1.0f, 0, {}, refined);
  for (int x = 0; x < raw.cols; ++x) {
    const float expected = x < 20 ? 10.0f : 30.0f;
    EXPECT_NEAR(refined.at<float>(12, x), expected, 0.51f) << "column " << x;
  }
  EXPECT_FLOAT_EQ(refined.at<float>(12, 2), 10.5f);  // departures below the limit stay
}

// A filter whose halo departs from the raw winners by less than the limit:
// only the zone along the break yields to the median.
TEST(KeepEdgesOfRawWinners, TakesTheMedianNearABreak) {
  const cv::Mat raw = Step({80, 24});
  const cv::Mat weight(raw.size(), CV_32FC1, cv::Scalar(1.0f));
  cv::Mat refined = raw + 0.5f;
  refined.colRange(14, 20) += 0.4f;  // a halo on the far side, 0.9 < the limit
  const int radius = 4;
  KeepEdgesOfRawWinners(raw, weight, 1.0f, radius, Bound(5.0f, 0.0f, 0.0f), refined);
  for (int x = 0; x < raw.cols; ++x) {
    const bool near = x >= 20 - radius && x < 20 + radius;  // within 4 of the other side
    const float departure = near ? 0.0f : (x >= 14 && x < 20 ? 0.9f : 0.5f);
    const float expected = (x < 20 ? 10.0f : 30.0f) + departure;
    EXPECT_FLOAT_EQ(refined.at<float>(12, x), expected) << "column " << x;
  }
}

TEST(KeepEdgesOfRawWinners, PixelsWithoutWeightEnterWithTheirRefinedValue) {
  const cv::Mat raw(16, 16, CV_32FC1, cv::Scalar(-1.0f));  // no winner anywhere
  const cv::Mat weight = cv::Mat::zeros(raw.size(), CV_32FC1);
  cv::Mat refined(raw.size(), CV_32FC1, cv::Scalar(7.0f));
  KeepEdgesOfRawWinners(raw, weight, 0.1f, 0, {}, refined);
  EXPECT_EQ(cv::countNonZero(refined != 7.0f), 0);
}

TEST(InvalidateAlongDiscontinuities, ClearsABandAlongTheStepOnly) {
  const cv::Mat plane = Step();
  cv::Mat weight(plane.size(), CV_32FC1, cv::Scalar(1.0f));
  InvalidateAlongDiscontinuities(plane, 2, Bound(5.0f, 0.0f, 0.0f), weight);
  for (int x = 0; x < plane.cols; ++x) {
    const bool near = x >= 18 && x <= 21;  // within 2 of the other side
    EXPECT_EQ(weight.at<float>(10, x) == 0.0f, near) << "column " << x;
  }
}

TEST(InvalidateAlongDiscontinuities, InvalidPixelsDoNotWidenTheSpanAndSmallSpansStay) {
  cv::Mat plane(20, 20, CV_32FC1, cv::Scalar(50.0f));
  cv::Mat weight(plane.size(), CV_32FC1, cv::Scalar(1.0f));
  plane.at<float>(10, 10) = -1.0f;  // no depth there
  weight.at<float>(10, 10) = 0.0f;
  plane.colRange(0, 5).setTo(53.0f);  // a slant-like change below the limit
  InvalidateAlongDiscontinuities(plane, 2, Bound(5.0f, 0.0f, 0.0f), weight);
  EXPECT_EQ(cv::countNonZero(weight), 20 * 20 - 1);
  InvalidateAlongDiscontinuities(plane, 0, Bound(0.0f, 0.0f, 0.0f), weight);  // radius 0: off
  EXPECT_EQ(cv::countNonZero(weight), 20 * 20 - 1);
}

// The same step in planes is a break between surfaces far away and relief on
// a near one: only the relative bound tells them apart.
TEST(InvalidateAlongDiscontinuities, ASpanSmallAgainstTheInverseDepthStays) {
  const cv::Mat plane = Step();
  cv::Mat weight(plane.size(), CV_32FC1, cv::Scalar(1.0f));
  // Inverse depth 0 at plane -1000: the step is < 1 % of the inverse depth.
  InvalidateAlongDiscontinuities(plane, 2, Bound(5.0f, 0.1f, -1000.0f), weight);
  EXPECT_EQ(cv::countNonZero(weight), static_cast<int>(plane.total()));
  // Inverse depth 0 at plane 0: the same step is most of it.
  InvalidateAlongDiscontinuities(plane, 2, Bound(5.0f, 0.1f, 0.0f), weight);
  EXPECT_LT(cv::countNonZero(weight), static_cast<int>(plane.total()));
}

}  // namespace
}  // namespace dfsm
