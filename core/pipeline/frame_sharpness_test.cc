#include "core/pipeline/frame_sharpness.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "tests/support/random_texture.h"

namespace dfsm {
namespace {

TEST(FrameSharpness, ABlurredFrameFallsBelowTheSharpOnes) {
  for (const cv::Size size : {cv::Size(320, 240), cv::Size(1280, 720)}) {
    const cv::Mat sharp = RandomTexture(size.width, size.height, 4, 1.0);
    cv::Mat smeared;
    cv::filter2D(sharp, smeared, -1, cv::Mat::ones(1, 9, CV_32F) / 9.0);
    const std::vector<double> sharpness = RelativeSharpness({smeared, sharp, sharp.clone()});
    ASSERT_EQ(sharpness.size(), 3u);
    EXPECT_DOUBLE_EQ(sharpness[1], 1.0);
    EXPECT_DOUBLE_EQ(sharpness[2], 1.0);
    EXPECT_LT(sharpness[0], 0.5) << size;
    EXPECT_GT(sharpness[0], 0.0) << size;
  }
  // A flat burst has nothing to compare: every frame 1.
  const cv::Mat flat(10, 10, CV_8UC1, cv::Scalar(7));
  EXPECT_EQ(RelativeSharpness({flat, flat}), (std::vector<double>{1.0, 1.0}));
}

}  // namespace
}  // namespace dfsm
