#include "core/pipeline/repeated_frames.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace dfsm {
namespace {

// A textured frame shifted by `dx` pixels, with its own sensor noise.
cv::Mat Frame(double dx, int noise_seed) {
  cv::Mat texture(120, 160, CV_8UC1);
  cv::RNG pattern(7);
  pattern.fill(texture, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 2.0);
  cv::Mat shifted;
  const cv::Mat move = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, 0);
  cv::warpAffine(texture, shifted, move, texture.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  cv::Mat noise(shifted.size(), CV_16SC1);
  cv::RNG(noise_seed).fill(noise, cv::RNG::NORMAL, 0, 2.0);
  cv::Mat noisy;
  shifted.convertTo(noisy, CV_16SC1);
  noisy += noise;
  noisy.convertTo(noisy, CV_8UC1);
  return noisy;
}

TEST(RepeatedFramesTest, FindsCopiesAndKeepsTheReference) {
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 8; ++i) frames.push_back(Frame(0.3 * i, i + 1));
  EXPECT_EQ(FindRepeatedFrames(frames, 4), std::vector<int>(8, -1));
  // Frame 3 copies 2, frames 5 and 6 copy 4 (the reference), frame 1 copies 0
  // with a JPEG-like wobble of a grey level here and there.
  frames[3] = frames[2].clone();
  frames[5] = frames[4].clone();
  frames[6] = frames[4].clone();
  frames[1] = frames[0].clone();
  frames[1](cv::Rect(10, 10, 20, 20)) += 1;
  EXPECT_EQ(FindRepeatedFrames(frames, 4), (std::vector<int>{-1, 0, -1, 2, -1, 4, 4, -1}));
  // The reference in the middle of a run stands for it.
  EXPECT_EQ(FindRepeatedFrames(frames, 6), (std::vector<int>{-1, 0, -1, 2, 6, 6, -1, -1}));
}

TEST(RepeatedFramesTest, HalfTheFramesRepeatedAreStillFound) {
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 10; ++i) frames.push_back(Frame(0.3 * (i / 2), i / 2 + 1));
  const std::vector<int> repeats = FindRepeatedFrames(frames, 0);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(repeats[i], i % 2 ? i - 1 : -1) << i;
}

TEST(RepeatedFramesTest, AStillCameraIsNotARepeat) {
  // Noise alone: every frame differs from the next by the same ~2 grey levels.
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 6; ++i) frames.push_back(Frame(0.0, i + 1));
  EXPECT_EQ(FindRepeatedFrames(frames, 0), std::vector<int>(6, -1));
}

}  // namespace
}  // namespace dfsm
