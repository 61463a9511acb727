#include "core/dense/depth_completion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace dfsm {
namespace {

TEST(DepthCompletionTest, FillsEveryHoleAndKeepsEveryMeasurement) {
  // Two surfaces split at x = 40 (an image edge too); a hole across the edge
  // and a large one inside the right surface.
  cv::Mat values(60, 80, CV_32FC1), guide(60, 80, CV_8UC1);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) {
      values.at<float>(y, x) = x < 40 ? 10.0f : 30.0f;
      guide.at<uchar>(y, x) = x < 40 ? 50 : 200;
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
  // TUM's black monitor: a dark square (guide 12) in a bright scene (200),
  // measured only along its outline (depth 2) and everywhere outside (depth 8).
  cv::Mat values(80, 80, CV_32FC1, cv::Scalar(8.0f)), guide(80, 80, CV_8UC1, cv::Scalar(200));
  const cv::Rect square(20, 20, 40, 40);
  guide(square).setTo(12);
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
  cv::Mat values(80, 80, CV_32FC1, cv::Scalar(8.0f)), guide(80, 80, CV_8UC1, cv::Scalar(25));
  const cv::Rect square(20, 20, 40, 40);
  guide(square).setTo(230);
  cv::Mat weight(values.size(), CV_32FC1, cv::Scalar(1.0f));
  weight(square).setTo(0.0f);
  values(square).setTo(0.0f);  // no value to leak
  const cv::Mat filled = FillHoles(values, weight, guide);
  EXPECT_NEAR(filled.at<float>(40, 40), 8.0f, 0.05f);
  EXPECT_NEAR(filled.at<float>(21, 21), 8.0f, 0.05f);
}

TEST(DepthCompletionTest, AColourEdgeOfOneBrightnessStopsTheFill) {
  // An orange wall (depth 4) behind a grey photo (depth 1) of the same
  // brightness, the wall measured only far from the photo: its hole beside
  // the photo takes the wall's depth from the colour guide; a grey guide sees
  // no edge and lets the photo's depth in.
  const cv::Vec3b orange(30, 140, 225), grey(153, 153, 153);  // BGR, both grey level 153
  cv::Mat color(40, 80, CV_8UC3, cv::Scalar(orange[0], orange[1], orange[2]));
  color.colRange(0, 40).setTo(cv::Scalar(grey[0], grey[1], grey[2]));
  cv::Mat gray;
  cv::cvtColor(color, gray, cv::COLOR_BGR2GRAY);
  ASSERT_LE(std::abs(gray.at<uchar>(20, 10) - gray.at<uchar>(20, 70)), 1);
  cv::Mat values(color.size(), CV_32FC1, cv::Scalar(4.0f));
  values.colRange(0, 40).setTo(1.0f);
  cv::Mat weight(color.size(), CV_32FC1, cv::Scalar(1.0f));
  weight.colRange(40, 70).setTo(0.0f);  // the wall's hole, beside the photo
  EXPECT_NEAR(FillHoles(values, weight, color).at<float>(20, 42), 4.0f, 0.05f);
  EXPECT_LT(FillHoles(values, weight, gray).at<float>(20, 42), 3.0f);
}

TEST(DepthCompletionTest, TheGuidesMedianLetsTheFillThroughNoiseButNotAcrossAnEdge) {
  // A wall (depth 4) measured at its left end and crossed by one-pixel lines
  // 60 levels off (the streaks of chroma noise and JPEG), and a photo (depth
  // 1) beyond a clean edge at x = 60. Without the median every line stops
  // the spread and the wall's hole is filled from its surroundings, the
  // photo nearest; with it the wall's depth reaches the hole's far end and
  // still stops at the photo's edge.
  cv::Mat guide(40, 80, CV_8UC3, cv::Scalar(40, 120, 200));
  guide.colRange(60, 80).setTo(cv::Scalar(150, 150, 150));
  for (int x = 14; x < 58; x += 4) guide.col(x).setTo(cv::Scalar(100, 120, 200));
  cv::Mat values(guide.size(), CV_32FC1, cv::Scalar(4.0f));
  values.colRange(60, 80).setTo(1.0f);
  cv::Mat weight(guide.size(), CV_32FC1, cv::Scalar(1.0f));
  weight.colRange(10, 60).setTo(0.0f);  // the wall's hole
  DepthCompletionOptions without;
  without.guide_median = 0;
  EXPECT_NEAR(FillHoles(values, weight, guide).at<float>(20, 57), 4.0f, 0.1f);
  EXPECT_LT(FillHoles(values, weight, guide, without).at<float>(20, 57), 3.5f);
}

TEST(DepthCompletionTest, TheConfidentInteriorOutweighsAFringe) {
  // One region of even brightness: its confident interior (depth 10,
  // confidence 0.9) and, between it and a hole, a fringe of low confidence
  // (0.2) that carries another surface's depth (30), as the window at a depth
  // edge leaves it. The power pulls the hole towards the interior.
  const cv::Mat guide(20, 60, CV_8UC1, cv::Scalar(128));
  cv::Mat values(guide.size(), CV_32FC1, cv::Scalar(10.0f));
  cv::Mat weight(guide.size(), CV_32FC1, cv::Scalar(0.9f));
  values.colRange(20, 26).setTo(30.0f);
  weight.colRange(20, 26).setTo(0.2f);
  weight.colRange(26, 60).setTo(0.0f);
  DepthCompletionOptions linear;
  linear.confidence_power = 1.0;
  const float with_power = FillHoles(values, weight, guide).at<float>(10, 40);
  const float without = FillHoles(values, weight, guide, linear).at<float>(10, 40);
  EXPECT_LT(with_power, without - 1.0f);
  EXPECT_GT(with_power, 10.0f);
}

// A varied scene (depth and texture change across the image, confidences
// between 0.05 and 1) with bright squares whose outlines hold no
// measurement, so the spread leaves them to the fallback: in the image's
// corner, across tile boundaries, at its right and bottom edges and alone in
// the middle.
void SceneWithUnreachedSquares(const cv::Size& size, cv::Mat* values, cv::Mat* weight,
                               cv::Mat* guide, std::vector<cv::Rect>* squares) {
  values->create(size, CV_32FC1);
  weight->create(size, CV_32FC1);
  guide->create(size, CV_8UC1);
  cv::RNG random(7);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      values->at<float>(y, x) = 1.0f + 0.002f * x + 0.5f * std::sin(0.03f * y);
      weight->at<float>(y, x) = static_cast<float>(random.uniform(0.05, 1.0));
      guide->at<uchar>(y, x) = static_cast<uchar>(40 + (x / 7 + y / 5) % 3 * 20);
    }
  const int w = size.width, h = size.height;
  *squares = {cv::Rect(0, 0, 30, 24), cv::Rect(60, 50, 40, 30), cv::Rect(w - 26, h / 2, 26, 20),
              cv::Rect(w / 2 + 3, h / 3 + 5, 17, 21), cv::Rect(w / 3, h - 15, 33, 15)};
  for (const cv::Rect& square : *squares) {
    (*guide)(square).setTo(250);
    (*weight)(square).setTo(0.0f);
  }
}

TEST(DepthCompletionTest, TheFallbackInTilesIsTheFallbackOverTheWholeImage) {
  // 1280x720 subsamples the guided pass by 2, 640x480 and 641x481 do not
  // (tiles at any size); 1281x721 has no exact half, and goes over the whole
  // image either way.
  for (const cv::Size size :
       {cv::Size(1280, 720), cv::Size(640, 480), cv::Size(641, 481), cv::Size(1281, 721)}) {
    cv::Mat values, weight, guide;
    std::vector<cv::Rect> squares;
    SceneWithUnreachedSquares(size, &values, &weight, &guide, &squares);
    DepthCompletionOptions whole;
    whole.fallback_tile = 0;
    const cv::Mat expected = FillHoles(values, weight, guide, whole);
    const cv::Mat tiled = FillHoles(values, weight, guide);
    ASSERT_FALSE(expected.empty());
    cv::Mat difference;
    cv::absdiff(tiled, expected, difference);
    double largest = 0.0, highest = 0.0;
    cv::minMaxLoc(difference, nullptr, &largest);
    cv::minMaxLoc(cv::abs(expected), nullptr, &highest);
    EXPECT_LE(largest, 1e-5 * highest) << size;
    for (const cv::Rect& square : squares) {
      // Filled, from the depths around (0.5 to 4.1 in this scene), not left at 0.
      const cv::Point centre(square.x + square.width / 2, square.y + square.height / 2);
      EXPECT_GT(tiled.at<float>(centre), 0.4f) << size << " " << square;
    }
  }
  DepthCompletionOptions odd;
  odd.fallback_tile = 33;
  EXPECT_THROW(odd.Check(), std::invalid_argument);
}

TEST(DepthCompletionTest, NothingToFillFrom) {
  const cv::Mat values(8, 8, CV_32FC1, cv::Scalar(1.0f));
  const cv::Mat zero(8, 8, CV_32FC1, cv::Scalar(0.0f));
  const cv::Mat guide(8, 8, CV_8UC1, cv::Scalar(100));
  EXPECT_TRUE(FillHoles(values, zero, guide).empty());
  DepthCompletionOptions bad;
  bad.filled_weight = 0.0f;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
  bad = {};
  bad.confidence_power = 0.0;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
  bad = {};
  bad.guide_median = 4;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
