#include "core/dense/dense_frames.h"

#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/core.hpp>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/dense/high_pass.h"
#include "core/dense/sweep_level.h"

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

DenseFramesSettings Settings(double fine_sigma, double coarse_sigma, double prefilter,
                             int coarse_scale) {
  DenseFramesSettings settings;
  settings.fine_high_pass_sigma = fine_sigma;
  settings.coarse_high_pass_sigma = coarse_sigma;
  settings.prefilter_sigma = prefilter;
  settings.coarse_scale = coarse_scale;
  return settings;
}

// The frames are each frame's high-pass at the fine sigma, prefiltered, and
// the coarse level's at the coarse sigma, prefiltered and downsampled: made
// one by one from other threads in another order, they are the same bits.
TEST(DenseFrames, MadeInAnyOrderFromAnyThreadTheyAreTheSame) {
  const Burst burst = NoiseBurst(5, 160, 120);
  const DenseFramesSettings settings = Settings(1.2, 2.0, 0.5, 2);
  const DenseFrames whole = PrepareDenseFrames(burst, settings);
  EXPECT_TRUE(whole.settings == settings);
  EXPECT_EQ(whole.reference, 2);
  ASSERT_EQ(whole.others.size(), 4u);
  EXPECT_TRUE(SameBits(whole.reference_gray, HighPass(burst.gray[2], 1.2)));
  EXPECT_TRUE(SameBits(whole.reference_filtered, Prefiltered(whole.reference_gray, 0.5)));
  EXPECT_TRUE(SameBits(whole.others[2], Prefiltered(HighPass(burst.gray[3], 1.2), 0.5)));
  ASSERT_EQ(whole.coarse_others.size(), 4u);
  EXPECT_TRUE(SameBits(whole.coarse_reference,
                       DownsampleToLevel(Prefiltered(HighPass(burst.gray[2], 2.0), 0.5), 2)));
  EXPECT_TRUE(SameBits(whole.coarse_others[2],
                       DownsampleToLevel(Prefiltered(HighPass(burst.gray[3], 2.0), 0.5), 2)));
  EXPECT_EQ(whole.coarse_others[0].size(), cv::Size(80, 60));

  DenseFramesMaker maker(burst, settings);
  std::vector<std::thread> threads;
  for (const int i : {4, 0, 3}) threads.emplace_back([&maker, i] { maker.MakeFrame(i); });
  for (std::thread& thread : threads) thread.join();
  maker.MakeFrame(2);
  EXPECT_THROW(maker.Take(), std::logic_error);  // frame 1 is not made
  maker.MakeFrame(1);
  const DenseFrames pieces = maker.Take();
  EXPECT_TRUE(SameBits(pieces.reference_gray, whole.reference_gray));
  EXPECT_TRUE(SameBits(pieces.reference_filtered, whole.reference_filtered));
  EXPECT_TRUE(SameBits(pieces.coarse_reference, whole.coarse_reference));
  for (size_t n = 0; n < whole.others.size(); ++n) {
    EXPECT_TRUE(SameBits(pieces.others[n], whole.others[n])) << "frame " << n;
    EXPECT_TRUE(SameBits(pieces.coarse_others[n], whole.coarse_others[n])) << "frame " << n;
  }
  ASSERT_EQ(pieces.frame_ms.size(), 5u);
  // Each frame's time is its own: the frames made one at a time took time each.
  for (const double ms : pieces.frame_ms) EXPECT_GT(ms, 0.0);
  EXPECT_THROW(maker.Take(), std::logic_error);  // taken already
}

// Where the two sigmas agree, or there is no coarse level below full
// resolution, the coarse level is downsampled from the full-resolution frames:
// no frames of its own are made.
TEST(DenseFrames, OneSigmaMakesNoCoarseFrames) {
  const Burst burst = NoiseBurst(3, 64, 48);
  for (const DenseFramesSettings& settings :
       {Settings(2.0, 2.0, 0.5, 2), Settings(1.0, 2.0, 0.5, 1)}) {
    const DenseFrames frames = PrepareDenseFrames(burst, settings);
    EXPECT_FALSE(settings.SeparateCoarseFrames());
    EXPECT_TRUE(frames.coarse_reference.empty());
    EXPECT_TRUE(frames.coarse_others.empty());
    EXPECT_TRUE(
        SameBits(frames.reference_gray, HighPass(burst.gray[1], settings.fine_high_pass_sigma)));
  }
}

// A sigma of 0 is no high-pass: the reference is the frame itself.
TEST(DenseFrames, WithoutTheHighPassTheReferenceIsTheFrame) {
  const Burst burst = NoiseBurst(3, 64, 48);
  const DenseFrames frames = PrepareDenseFrames(burst, Settings(0.0, 0.0, 0.0, 2));
  EXPECT_TRUE(SameBits(frames.reference_gray, burst.gray[1]));
  cv::Mat as_float;
  burst.gray[0].convertTo(as_float, CV_32F);
  EXPECT_TRUE(SameBits(frames.others[0], as_float));
}

}  // namespace
}  // namespace dfsm
