#include "core/pipeline/photometric_compensation.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "core/synth/burst_synthesizer.h"

namespace dfsm {
namespace {

std::vector<cv::Mat> GrayFrames(const SynthOptions& options) {
  return ToBurst(SynthesizeBurst(options)).gray;
}

SynthOptions Vga() {
  SynthOptions options;
  options.width = 640;
  options.height = 480;
  options.frames = 4;
  options.rotation_deg = 1.0;
  options.supersampling = 1;
  return options;
}

// A burst without drift is left bit-exact: its motion alone must not look
// like an exposure change.
TEST(PhotometricCompensation, LeavesADriftFreeBurstAlone) {
  std::vector<cv::Mat> frames = GrayFrames(Vga());
  const std::vector<cv::Mat> before = frames;
  const std::vector<FrameCompensation> result = CompensateExposure(&frames, 0);
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_FALSE(result[i].applied) << "frame " << i << " gain " << result[i].gain;
    EXPECT_NEAR(result[i].gain, 1.0, 0.02);
    EXPECT_EQ(cv::norm(frames[i], before[i], cv::NORM_INF), 0.0);
  }
}

// Auto exposure scales a frame; the compensation finds the scale and undoes it.
TEST(PhotometricCompensation, FindsAndUndoesAnExposureChange) {
  SynthOptions options = Vga();
  const std::vector<cv::Mat> plain = GrayFrames(options);
  options.effects.exposure_drift = 0.15;
  std::vector<cv::Mat> drifting = GrayFrames(options);
  const std::vector<FrameCompensation> result = CompensateExposure(&drifting, 0);
  EXPECT_FALSE(result[0].applied);  // the reference
  int applied = 0;
  for (size_t i = 1; i < drifting.size(); ++i) {
    applied += result[i].applied;
    // After compensation the frame is within ~2 % of its drift-free brightness.
    EXPECT_NEAR(cv::mean(drifting[i])[0] / cv::mean(plain[i])[0], 1.0, 0.025) << "frame " << i;
  }
  EXPECT_GE(applied, 1);
}

// Switched off, a drifting burst that the compensation would change is left
// bit-exact, and every frame is reported as not compensated.
TEST(PhotometricCompensation, CanBeSwitchedOff) {
  SynthOptions options = Vga();
  options.effects.exposure_drift = 0.15;
  const std::vector<cv::Mat> original = GrayFrames(options);
  std::vector<cv::Mat> on = original;
  for (cv::Mat& frame : on) frame = frame.clone();
  const std::vector<FrameCompensation> compensated = CompensateExposure(&on, 0);
  ASSERT_TRUE(std::any_of(compensated.begin(), compensated.end(),
                          [](const FrameCompensation& c) { return c.applied; }));
  std::vector<cv::Mat> frames = original;
  for (cv::Mat& frame : frames) frame = frame.clone();
  PhotometricCompensationOptions off;
  off.enabled = false;
  const std::vector<FrameCompensation> result = CompensateExposure(&frames, 0, off);
  ASSERT_EQ(result.size(), frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_FALSE(result[i].applied) << "frame " << i;
    EXPECT_EQ(cv::norm(frames[i], original[i], cv::NORM_INF), 0.0) << "frame " << i;
  }
}

}  // namespace
}  // namespace dfsm
