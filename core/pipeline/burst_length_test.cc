#include "core/pipeline/burst_length.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "core/io/burst.h"
#include "core/pipeline/pipeline.h"
#include "core/synth/burst_synthesizer.h"

namespace dfsm {
namespace {

// A burst of `frames` flat frames, frame i of grey level i, its reference
// `reference`.
Burst Numbered(int frames, int reference) {
  Burst burst;
  burst.manifest.width = 8;
  burst.manifest.height = 6;
  burst.manifest.reference = reference;
  for (int i = 0; i < frames; ++i) {
    burst.manifest.frames.push_back({"frames/" + std::to_string(i) + ".png", 1000 * i, i});
    burst.gray.push_back(cv::Mat(6, 8, CV_8UC1, cv::Scalar(i)));
  }
  burst.reference_color = burst.gray[reference];
  return burst;
}

Burst Rendered(double baseline_m, double rotation_deg) {
  SynthOptions options;
  options.width = 320;
  options.height = 240;
  options.frames = 20;
  options.baseline = baseline_m;
  options.rotation_deg = rotation_deg;
  options.supersampling = 1;
  options.seed = 5;
  return ToBurst(SynthesizeBurst(options));
}

TEST(BurstLengthOptions, CheckNamesTheBadOption) {
  const auto error = [](const BurstLengthOptions& options) -> std::string {
    try {
      options.Check();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error({}), "");
  BurstLengthOptions options;
  options.lengths = {15, 10};
  EXPECT_NE(error(options).find("ascending"), std::string::npos);
  options = {};
  options.lengths = {2};
  EXPECT_NE(error(options).find("at least 3"), std::string::npos);
  options = {};
  options.min_parallax_px = 3.0;  // above the target
  EXPECT_NE(error(options).find("min_parallax_px"), std::string::npos);
}

// The frames nearest the reference: a capture's first frames where it took
// the next ones, its last where it took those already in the ring, and
// those around a reference between.
TEST(FramesFromReference, TakesTheFramesNearestTheReference) {
  const Burst forward = FramesFromReference(Numbered(12, 0), 5);
  ASSERT_EQ(forward.size(), 5);
  EXPECT_EQ(forward.reference(), 0);
  EXPECT_EQ(forward.gray[4].at<uint8_t>(0, 0), 4);
  const Burst backward = FramesFromReference(Numbered(12, 11), 5);
  ASSERT_EQ(backward.size(), 5);
  EXPECT_EQ(backward.reference(), 4);
  EXPECT_EQ(backward.gray[0].at<uint8_t>(0, 0), 7);
  EXPECT_EQ(backward.gray[4].at<uint8_t>(0, 0), 11);
  const Burst around = FramesFromReference(Numbered(12, 5), 5);
  EXPECT_EQ(around.reference(), 2);
  EXPECT_EQ(around.gray[0].at<uint8_t>(0, 0), 3);
  EXPECT_EQ(around.gray[4].at<uint8_t>(0, 0), 7);
  EXPECT_EQ(FramesFromReference(Numbered(12, 10), 5).gray[0].at<uint8_t>(0, 0), 7);
  EXPECT_THROW(FramesFromReference(Numbered(12, 0), 13), std::invalid_argument);
}

TEST(ChooseBurstLength, StopsWhereTheParallaxSufficesAndTakesAllWhereItDoesNot) {
  const Burst burst = Rendered(0.02, 1.0);
  BurstLengthOptions options;
  options.target_parallax_px = 0.3;
  options.min_parallax_px = 0.1;
  const BurstLength early = ChooseBurstLength(burst, PipelineOptions(), options);
  EXPECT_EQ(early.reason, BurstLengthReason::kParallaxReached);
  EXPECT_EQ(early.frames, 10);
  ASSERT_EQ(early.trials.size(), 1u);
  EXPECT_GE(early.parallax_px, 0.3);

  options.target_parallax_px = 1000.0;
  const BurstLength all = ChooseBurstLength(burst, PipelineOptions(), options);
  EXPECT_EQ(all.reason, BurstLengthReason::kAllFrames);
  EXPECT_EQ(all.frames, 20);
  ASSERT_EQ(all.trials.size(), 3u);  // 10, 15, then all 20
  EXPECT_EQ(all.trials[1].frames, 15);
  // More frames, a longer path: the parallax grows.
  EXPECT_GT(all.trials[2].parallax_px, all.trials[0].parallax_px);
  const nlohmann::json json = ToJson(all, burst.size(), options);
  EXPECT_EQ(json.at("reason"), "all frames");
  EXPECT_EQ(json.at("of"), 20);
  EXPECT_EQ(json.at("trials").size(), 3u);
}

// A trial's parallax is the figure result.json gives for those frames: the
// pipeline's own, after its exposure compensation (the frames here brighten
// by 3 % each), and the progress hears each trial.
TEST(ChooseBurstLength, TakesThePipelinesParallaxAndReportsEachTrial) {
  Burst burst = Rendered(0.02, 1.0);
  for (int i = 0; i < burst.size(); ++i) burst.gray[i].convertTo(burst.gray[i], -1, 1.0 + 0.03 * i);
  BurstLengthOptions options;
  options.target_parallax_px = 1000.0;
  std::vector<double> fractions;
  const BurstLength all = ChooseBurstLength(burst, PipelineOptions(), options,
                                            [&](const std::string& lap, double fraction) {
                                              EXPECT_EQ(lap, kBurstLengthLap);
                                              fractions.push_back(fraction);
                                            });
  EXPECT_EQ(fractions, (std::vector<double>{1.0 / 3.0, 2.0 / 3.0, 1.0}));
  ASSERT_EQ(all.trials.size(), 3u);
  for (const BurstLengthTrial& trial : all.trials) {
    const Result result = RunPipeline(FramesFromReference(burst, trial.frames), {}).result;
    ASSERT_TRUE(result.ok) << result.error;
    EXPECT_EQ(trial.parallax_px, result.extra.at("parallax").at("median_px").get<double>())
        << trial.frames << " frames";
  }
}

// A camera that turns and does not move shows no depth, however far it
// turns: the burst is too still.
TEST(ChooseBurstLength, ACameraThatOnlyTurnsIsTooStill) {
  const BurstLength length =
      ChooseBurstLength(Rendered(0.0, 1.0), PipelineOptions(), BurstLengthOptions());
  EXPECT_EQ(length.reason, BurstLengthReason::kTooStill) << ToJson(length, 20, {}).dump();
  EXPECT_LT(length.parallax_px, BurstLengthOptions().min_parallax_px);
}

}  // namespace
}  // namespace dfsm
