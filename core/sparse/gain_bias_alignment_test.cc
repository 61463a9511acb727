#include "core/sparse/gain_bias_alignment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "core/sparse/grided_features.h"
#include "tests/support/random_texture.h"

namespace dfsm {
namespace {

cv::Mat SmoothTexture(int width, int height, uint64_t seed) {
  return RandomTexture(width, height, seed, 2.0);
}

// `image` shifted by (dx, dy), then seen through a brightness field: a gain
// rising linearly from `gain_left` at the left edge to `gain_right` at the
// right (a white-balance or vignetting change across the frame), plus `bias`.
// Shifts are multiples of 1/32 px and bilinear: OpenCV's warps quantize the
// position to 1/32 px, and its cubic warp moved the content by 0.40 px where
// 0.37 was asked (KLT and this aligner agree on that).
cv::Mat ShiftAndRelight(const cv::Mat& image, double dx, double dy, double gain_left,
                        double gain_right, double bias) {
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, dy);
  cv::Mat shifted;
  cv::warpAffine(image, shifted, M, image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  cv::Mat relit(image.size(), CV_8UC1);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      const double gain = gain_left + (gain_right - gain_left) * x / (image.cols - 1);
      relit.at<uchar>(y, x) = cv::saturate_cast<uchar>(gain * shifted.at<uchar>(y, x) + bias);
    }
  return relit;
}

TEST(GainBiasAlignment, OptionsCheck) {
  EXPECT_NO_THROW(GainBiasAlignmentOptions{}.Check());
  GainBiasAlignmentOptions even;
  even.window = 20;
  EXPECT_THROW(even.Check(), std::invalid_argument);
  GainBiasAlignmentOptions gain;
  gain.max_gain = 1.0;
  EXPECT_THROW(gain.Check(), std::invalid_argument);
}

TEST(GainBiasAlignment, RecoversTheShiftUnderAGainAndABias) {
  const cv::Mat reference = SmoothTexture(320, 240, 5);
  const cv::Mat frame = ShiftAndRelight(reference, 0.375, -0.625, 0.8, 0.8, 12.0);
  const GainBiasAligner aligner(reference, {});
  int aligned = 0;
  double error_x = 0.0, error_y = 0.0, worst = 0.0;
  for (int y = 40; y < 200; y += 20) {
    for (int x = 40; x < 280; x += 20) {
      const cv::Point2f corner(static_cast<float>(x), static_cast<float>(y));
      cv::Point2f position = corner + cv::Point2f(0.2f, -0.4f);  // a start off by 0.2 px
      GainBiasAligner::Patch patch;
      ASSERT_TRUE(aligner.Prepare(corner, &patch)) << corner;
      ASSERT_TRUE(aligner.Align(patch, frame, &position)) << corner;
      const double ex = position.x - corner.x - 0.375, ey = position.y - corner.y + 0.625;
      error_x += ex;
      error_y += ey;
      worst = std::max(worst, std::hypot(ex, ey));
      ++aligned;
    }
  }
  ASSERT_EQ(aligned, 96);
  std::printf("mean error %.4f, %.4f px, worst %.4f px\n", error_x / aligned, error_y / aligned,
              worst);
  // The frame is rounded to 8 bits after the gain and blurred by the bilinear
  // warp: each patch scatters by hundredths of a pixel, their mean does not.
  EXPECT_LT(std::abs(error_x / aligned), 0.005);
  EXPECT_LT(std::abs(error_y / aligned), 0.005);
  EXPECT_LT(worst, 0.06);
}

// A patch turned by 3 degrees and sheared (a roll and a rolling shutter
// under a large tremor): aligned through its shape, each lands within a few
// hundredths of a pixel; as a translation, tenths off or refused.
TEST(GainBiasAlignment, APatchTurnedAndShearedIsAlignedThroughItsShape) {
  const cv::Mat reference = SmoothTexture(320, 240, 7);
  const double angle = 3.0 * M_PI / 180.0, shear = 0.03;
  // Frame position = A (reference position - centre) + centre + t.
  const cv::Matx22d A =
      cv::Matx22d(1.0, shear, 0.0, 1.0) *
      cv::Matx22d(std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle));
  const cv::Point2d centre(160.0, 120.0), t(4.25, -2.5);
  const cv::Matx23d forward(A(0, 0), A(0, 1),
                            centre.x + t.x - A(0, 0) * centre.x - A(0, 1) * centre.y, A(1, 0),
                            A(1, 1), centre.y + t.y - A(1, 0) * centre.x - A(1, 1) * centre.y);
  cv::Mat frame;
  cv::warpAffine(reference, frame, cv::Mat(forward), reference.size(), cv::INTER_LINEAR,
                 cv::BORDER_REFLECT);
  const float shape[4] = {static_cast<float>(A(0, 0)), static_cast<float>(A(0, 1)),
                          static_cast<float>(A(1, 0)), static_cast<float>(A(1, 1))};
  const GainBiasAligner aligner(reference, {});
  double worst_shaped = 0.0, worst_translated = 0.0;
  int refused_translated = 0, compared = 0;
  for (int y = 50; y < 200; y += 25) {
    for (int x = 50; x < 280; x += 25) {
      const cv::Point2f corner(static_cast<float>(x), static_cast<float>(y));
      const cv::Point2d d = cv::Point2d(corner) - centre;
      const cv::Point2d truth(A(0, 0) * d.x + A(0, 1) * d.y + centre.x + t.x,
                              A(1, 0) * d.x + A(1, 1) * d.y + centre.y + t.y);
      const cv::Point2f start(static_cast<float>(truth.x + 0.3), static_cast<float>(truth.y - 0.2));
      GainBiasAligner::Patch patch;
      ASSERT_TRUE(aligner.Prepare(corner, &patch));
      cv::Point2f shaped = start, translated = start;
      ASSERT_TRUE(aligner.Align(patch, frame, shape, &shaped)) << corner;
      worst_shaped = std::max(worst_shaped, cv::norm(cv::Point2d(shaped) - truth));
      ++compared;
      if (aligner.Align(patch, frame, &translated))
        worst_translated = std::max(worst_translated, cv::norm(cv::Point2d(translated) - truth));
      else
        ++refused_translated;
    }
  }
  std::printf("worst %.4f px through the shape; as a translation %.4f px, %d of %d refused\n",
              worst_shaped, worst_translated, refused_translated, compared);
  EXPECT_LT(worst_shaped, 0.05);
  EXPECT_TRUE(worst_translated > 0.1 || refused_translated > compared / 4);
}

TEST(GainBiasAlignment, RefusesWhatAGainCannotExplain) {
  const cv::Mat bright = SmoothTexture(320, 240, 6);
  const cv::Mat dim = bright / 3;
  const GainBiasAligner aligner(dim, {});
  const cv::Point2f corner(160.0f, 120.0f);
  GainBiasAligner::Patch patch;
  ASSERT_TRUE(aligner.Prepare(corner, &patch));
  cv::Point2f position = corner;
  EXPECT_TRUE(aligner.Align(patch, dim, &position));
  // Three times brighter is beyond max_gain.
  EXPECT_FALSE(aligner.Align(patch, bright, &position));
  EXPECT_EQ(position, corner);  // left as it was
  // A window that leaves the image, in the reference or in the frame.
  EXPECT_FALSE(aligner.Prepare(cv::Point2f(5.0f, 120.0f), &patch));
  position = cv::Point2f(5.0f, 120.0f);
  EXPECT_FALSE(aligner.Align(patch, dim, &position));
}

// The tracker as the pipeline runs it: KLT alone is pulled by a brightness
// field that changes between frames; the gain-and-bias realignment is not.
TEST(GainBiasAlignment, TracksUnderABrightnessFieldThatKltAloneMisreads) {
  const cv::Mat reference = SmoothTexture(640, 480, 7);
  std::vector<cv::Mat> frames = {reference};
  std::vector<cv::Point2d> shifts = {{0, 0}};
  for (int i = 1; i < 5; ++i) {
    shifts.emplace_back(0.875 * i, 0.5 * i);
    frames.push_back(ShiftAndRelight(reference, shifts.back().x, shifts.back().y, 1.0 - 0.03 * i,
                                     1.0 + 0.03 * i, 3.0 * i));
  }
  GridedFeatureOptions klt_alone;
  klt_alone.gain_bias = false;
  const FeatureTracks klt = TrackGridedFeatures(frames, 0, klt_alone);
  const FeatureTracks realigned = TrackGridedFeatures(frames, 0, {});
  ASSERT_GT(klt.num_tracks(), 200);
  // The realignment drops a track whose window leaves a frame, or that KLT
  // missed by more than its shift bound; it keeps the rest.
  EXPECT_GE(realigned.num_tracks(), 0.85 * klt.num_tracks());
  // Compared over the tracks both keep (same reference corner), so that the
  // realignment cannot score by dropping the hard ones.
  const auto error = [&](const FeatureTracks& tracks, int j) {
    double sum = 0.0;
    for (int i = 1; i < tracks.num_frames(); ++i)
      sum += (tracks.pixels[i].col(j) - tracks.pixels[0].col(j) -
              Eigen::Vector2d(shifts[i].x, shifts[i].y))
                 .norm();
    return sum / (tracks.num_frames() - 1);
  };
  double sum_klt = 0.0, sum_realigned = 0.0;
  int common = 0;
  for (int j = 0, k = 0; j < realigned.num_tracks(); ++j) {
    while (k < klt.num_tracks() && klt.pixels[0].col(k) != realigned.pixels[0].col(j)) ++k;
    ASSERT_LT(k, klt.num_tracks()) << "a realigned track KLT alone does not have";
    sum_klt += error(klt, k);
    sum_realigned += error(realigned, j);
    ++common;
  }
  std::printf("%d of %d tracks kept; mean error on them: KLT alone %.4f px, realigned %.4f px\n",
              realigned.num_tracks(), klt.num_tracks(), sum_klt / common, sum_realigned / common);
  EXPECT_LT(sum_realigned / common, 0.03);
  EXPECT_LT(sum_realigned, 0.5 * sum_klt);
}

// The window may reach the last pixel but one (bilinear reads x0 + 1).
TEST(GainBiasAlignment, WindowsAtTheFramesEdges) {
  const cv::Mat reference = SmoothTexture(320, 240, 8);
  const GainBiasAligner aligner(reference, {});
  const float half = static_cast<float>(GainBiasAlignmentOptions{}.window / 2);
  GainBiasAligner::Patch patch;
  EXPECT_TRUE(aligner.Prepare(cv::Point2f(half, half), &patch));
  EXPECT_FALSE(aligner.Prepare(cv::Point2f(half - 0.5f, 120.0f), &patch));
  EXPECT_FALSE(aligner.Prepare(cv::Point2f(319.0f - half, 120.0f), &patch));
  const cv::Point2f corner(318.0f - half, 238.0f - half);
  ASSERT_TRUE(aligner.Prepare(corner, &patch));
  cv::Point2f position = corner;
  EXPECT_TRUE(aligner.Align(patch, reference, &position));
  EXPECT_NEAR(position.x, corner.x, 1e-3);
  EXPECT_NEAR(position.y, corner.y, 1e-3);
  // A start whose window would read the last column is refused.
  position = cv::Point2f(319.0f - half, 120.0f);
  EXPECT_FALSE(aligner.Align(patch, reference, &position));
}

}  // namespace
}  // namespace dfsm
