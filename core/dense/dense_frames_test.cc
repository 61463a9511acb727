#include "core/dense/dense_frames.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/dense/high_pass.h"

namespace dfsm {
namespace {

Burst NoiseBurst(int frames, int width, int height) {
  Burst burst;
  burst.manifest.width = width;
  burst.manifest.height = height;
  burst.manifest.reference = frames / 2;
  cv::RNG rng(3);
  for (int i = 0; i < frames; ++i) {
    cv::Mat frame(height, width, CV_8UC1);
    rng.fill(frame, cv::RNG::UNIFORM, 0, 256);
    burst.gray.push_back(frame);
  }
  return burst;
}

bool SameBits(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         cv::countNonZero(a.reshape(1) != b.reshape(1)) == 0;
}

// The frames are each frame's high-pass, prefiltered: made one by one from
// other threads in another order, they are the same bits.
TEST(DenseFrames, MadeInAnyOrderFromAnyThreadTheyAreTheSame) {
  const Burst burst = NoiseBurst(5, 160, 120);
  const DenseFrames whole = PrepareDenseFrames(burst, 0.0, 0.5);
  EXPECT_EQ(whole.high_pass_sigma, HighPassSigma(0.0, 160, 120));
  EXPECT_EQ(whole.reference, 2);
  ASSERT_EQ(whole.others.size(), 4u);
  EXPECT_TRUE(SameBits(whole.reference_gray, HighPass(burst.gray[2], whole.high_pass_sigma)));
  EXPECT_TRUE(SameBits(whole.reference_filtered, Prefiltered(whole.reference_gray, 0.5)));
  EXPECT_TRUE(
      SameBits(whole.others[2], Prefiltered(HighPass(burst.gray[3], whole.high_pass_sigma), 0.5)));

  DenseFramesMaker maker(burst, 0.0, 0.5);
  std::vector<std::thread> threads;
  for (const int i : {4, 0, 3}) threads.emplace_back([&maker, i] { maker.MakeFrame(i); });
  for (std::thread& thread : threads) thread.join();
  maker.MakeFrame(2);
  EXPECT_THROW(maker.Take(), std::logic_error);  // frame 1 is not made
  maker.MakeFrame(1);
  const DenseFrames pieces = maker.Take();
  EXPECT_TRUE(SameBits(pieces.reference_gray, whole.reference_gray));
  EXPECT_TRUE(SameBits(pieces.reference_filtered, whole.reference_filtered));
  for (size_t n = 0; n < whole.others.size(); ++n)
    EXPECT_TRUE(SameBits(pieces.others[n], whole.others[n])) << "frame " << n;
  ASSERT_EQ(pieces.frame_ms.size(), 5u);
  for (const double ms : pieces.frame_ms) EXPECT_GE(ms, 0.0);
  EXPECT_THROW(maker.Take(), std::logic_error);  // taken already
}

// A negative sigma is no high-pass: the reference is the frame itself.
TEST(DenseFrames, WithoutTheHighPassTheReferenceIsTheFrame) {
  const Burst burst = NoiseBurst(3, 64, 48);
  const DenseFrames frames = PrepareDenseFrames(burst, -1.0, 0.0);
  EXPECT_EQ(frames.high_pass_sigma, 0.0);
  EXPECT_TRUE(SameBits(frames.reference_gray, burst.gray[1]));
  cv::Mat as_float;
  burst.gray[0].convertTo(as_float, CV_32F);
  EXPECT_TRUE(SameBits(frames.others[0], as_float));
}

}  // namespace
}  // namespace dfsm
