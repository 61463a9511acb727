#include "core/dense/weak_texture.h"

#include <gtest/gtest.h>

namespace dfsm {
namespace {

// Left half: sensor-like noise (sigma 1 grey level) on a flat grey; right
// half: strong texture. The mask covers the flat half except within the
// radius of the textured one, where a wide window would reach into it.
TEST(WeakTextureMask, CoversFlatRegionsAwayFromStrongTexture) {
  cv::Mat image(60, 80, CV_32FC1);
  cv::RNG rng(3);
  rng.fill(image, cv::RNG::NORMAL, 128.0, 1.0);
  cv::Mat textured = image.colRange(40, 80);
  rng.fill(textured, cv::RNG::UNIFORM, 0.0, 255.0);
  const int radius = 5;
  const cv::Mat mask = WeakTextureMask(image, radius, 4.0);
  ASSERT_EQ(mask.type(), CV_8UC1);
  ASSERT_EQ(mask.size(), image.size());
  for (int x = 0; x < image.cols; ++x) {
    // Column 39's central difference already reaches the texture at 40.
    const bool weak = x < 40 - 1 - radius;
    EXPECT_EQ(mask.at<uchar>(30, x) != 0, weak) << "column " << x;
  }
  // A threshold below the noise's own gradient marks nothing.
  EXPECT_EQ(cv::countNonZero(WeakTextureMask(image, radius, 0.5)), 0);
}

}  // namespace
}  // namespace dfsm
