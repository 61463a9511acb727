#include "core/dense/weak_texture.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

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

// The mask is made in bands of rows; a band's rows must come out as the
// whole frame's: the same filters over the whole frame at once, here.
TEST(WeakTextureMask, InBandsIsTheMaskOfTheWholeFrame) {
  for (const cv::Size size : {cv::Size(1920, 1080), cv::Size(641, 479), cv::Size(90, 9)}) {
    // Noise of 1 grey level, with textured squares and stripes every few
    // bands, so that the mask has edges across the bands' boundaries.
    cv::Mat image(size, CV_32FC1);
    cv::RNG rng(5);
    rng.fill(image, cv::RNG::NORMAL, 128.0, 1.0);
    for (int y = 0; y < size.height; y += 97)
      for (int x = (y / 97 % 2) * 60; x < size.width; x += 120) {
        cv::Mat patch = image(cv::Rect(x, y, 40, 50) & cv::Rect({}, size));
        rng.fill(patch, cv::RNG::UNIFORM, 0.0, 255.0);
      }
    const int radius = 7;
    const double max_rms_gradient = 8.0;
    cv::Mat gx, gy;
    cv::Sobel(image, gx, CV_32F, 1, 0, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
    cv::Sobel(image, gy, CV_32F, 0, 1, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
    cv::Mat energy = gx.mul(gx) + gy.mul(gy);
    cv::boxFilter(energy, energy, -1, cv::Size(2 * radius + 1, 2 * radius + 1), cv::Point(-1, -1),
                  true, cv::BORDER_REPLICATE);
    const float max_energy = static_cast<float>(max_rms_gradient * max_rms_gradient);
    const cv::Mat expected = energy < max_energy;
    const cv::Mat mask = WeakTextureMask(image, radius, max_rms_gradient);
    // The box sums run down from each band's first row, so they may round
    // differently: a pixel within that rounding of the threshold may go
    // either way.
    cv::Mat undecided;
    cv::absdiff(energy, max_energy, undecided);
    const cv::Mat disagree = (mask != expected) & (undecided > 1e-5f * max_energy);
    EXPECT_EQ(cv::countNonZero(disagree), 0) << size;
    EXPECT_GT(cv::countNonZero(mask), 0) << size;
    EXPECT_LT(cv::countNonZero(mask), static_cast<int>(mask.total())) << size;
  }
}

}  // namespace
}  // namespace dfsm
