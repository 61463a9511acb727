#include "core/dense/frame_oversampling.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dfsm {
namespace {

// A cubic in x and y (plus a cross term): what Catmull-Rom reproduces
// half-way between pixels away from the replicated edges.
double Cubic(double x, double y) {
  return 40.0 + 0.9 * x - 0.6 * y + 0.02 * x * x - 0.015 * x * y + 0.0004 * y * y * y;
}

TEST(OversampleTwice, KeepsThePixelsAndInterpolatesHalfWayExactlyOnACubic) {
  cv::Mat image(23, 31, CV_32FC1);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) image.at<float>(y, x) = static_cast<float>(Cubic(x, y));
  const cv::Mat grid = OversampleTwice(image);
  ASSERT_EQ(grid.size(), cv::Size(2 * 31 - 1, 2 * 23 - 1));
  ASSERT_EQ(grid.type(), CV_32FC1);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x)
      ASSERT_EQ(grid.at<float>(2 * y, 2 * x), image.at<float>(y, x)) << x << "," << y;
  // Grid node (u, v) is captured position (u / 2, v / 2); the interpolation
  // reaches two pixels either way, so nodes within 2 pixels of an edge see
  // replicated values.
  for (int v = 4; v < grid.rows - 4; ++v)
    for (int u = 4; u < grid.cols - 4; ++u)
      ASSERT_NEAR(grid.at<float>(v, u), Cubic(0.5 * u, 0.5 * v), 2e-4) << u << "," << v;
}

TEST(OversampleTwice, StaysFiniteAndBoundedAtTheEdgesAndOnTinyImages) {
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(2, 1), cv::Size(1, 3), cv::Size(5, 4)}) {
    cv::Mat image(size, CV_32FC1);
    cv::randu(image, 0.0f, 255.0f);
    const cv::Mat grid = OversampleTwice(image);
    ASSERT_EQ(grid.size(), cv::Size(2 * size.width - 1, 2 * size.height - 1));
    double low, high;
    cv::minMaxLoc(grid, &low, &high);
    // One Catmull-Rom pass overshoots by at most 1/8 of the range, the two
    // passes (rows, then columns of the result) by at most 0.28 of it.
    EXPECT_GE(low, -0.28 * 255.0) << size;
    EXPECT_LE(high, 1.28 * 255.0) << size;
    EXPECT_TRUE(cv::checkRange(grid)) << size;
  }
}

}  // namespace
}  // namespace dfsm
