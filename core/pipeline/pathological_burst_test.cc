// Bursts the method cannot reconstruct, built the way a camera would deliver
// them: flat grey with sensor noise, all black, no motion, motion far beyond
// small motion, texture in one corner only. Each must fail with a named reason
// that states the measured quantity and the bound it missed, and write a
// result.json saying so; a good burst run right after still succeeds.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "core/io/file_util.h"
#include "core/pipeline/pipeline.h"
#include "core/synth/burst_synthesizer.h"

namespace dfsm {
namespace {

constexpr int kWidth = 320, kHeight = 240, kFrames = 8;

SynthBurst Generated() {
  SynthOptions options;
  options.width = kWidth;
  options.height = kHeight;
  options.frames = kFrames;
  options.supersampling = 2;
  options.seed = 7;
  return SynthesizeBurst(options);
}

// A burst of the given frames with a manifest as the burst reader makes it.
Burst FromFrames(std::vector<cv::Mat> frames) {
  Burst burst = ToBurst(Generated());
  burst.gray = std::move(frames);
  burst.reference_color = burst.gray[0];
  burst.manifest.pixel_format = "gray8";
  return burst;
}

cv::Mat Noisy(const cv::Mat& frame, cv::RNG* random) {
  cv::Mat noise(frame.size(), CV_32F);
  random->fill(noise, cv::RNG::NORMAL, 0.0, 1.5);
  cv::Mat as_float, out;
  frame.convertTo(as_float, CV_32F);
  cv::Mat(as_float + noise).convertTo(out, CV_8U);
  return out;
}

// Runs the pipeline, checks the failure and its result.json; returns the reason.
std::string FailureOf(const std::string& name, const Burst& burst) {
  PipelineOptions options;
  options.dense.planes = 32;
  PipelineOutput output = RunPipeline(burst, options);
  std::cout << name << ": " << (output.result.ok ? "ok" : output.result.error) << "\n";
  std::string warnings;
  for (const std::string& warning : output.result.warnings) warnings += "\n  " + warning;
  EXPECT_FALSE(output.result.ok) << name << " was reconstructed, with the warnings:" << warnings
                                 << "\n  and " << output.result.extra.dump();
  const auto dir = std::filesystem::temp_directory_path() /
                   ("dfsm_pathological_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  WritePipelineOutputs(dir, burst, &output);
  const auto result = nlohmann::json::parse(ReadFileToString(dir / "result.json"));
  EXPECT_EQ(result["status"], "failed") << name;
  EXPECT_EQ(result["error"], output.result.error) << name;
  EXPECT_FALSE(std::filesystem::exists(dir / "depth.tiff")) << name;
  std::filesystem::remove_all(dir);
  return output.result.error;
}

void ExpectHas(const std::string& reason, const std::string& part) {
  EXPECT_NE(reason.find(part), std::string::npos) << "'" << part << "' not in: " << reason;
}

TEST(PathologicalBurst, AllBlackHasNoTexture) {
  const std::string reason = FailureOf(
      "all_black",
      FromFrames(std::vector<cv::Mat>(kFrames, cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(0)))));
  ExpectHas(reason, "no texture");
  ExpectHas(reason, "0 of ");       // corners found, of the cells searched
  ExpectHas(reason, "need >= 20");  // the bound
  ExpectHas(reason, "contrast 0.0 grey levels");
}

TEST(PathologicalBurst, FlatGreyWithSensorNoiseHasNoTexture) {
  // Noise alone gives every cell a "strongest corner" relative to the
  // strongest in the image; none of them is a point of the scene.
  cv::RNG random(3);
  std::vector<cv::Mat> frames;
  for (int i = 0; i < kFrames; ++i)
    frames.push_back(Noisy(cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(128)), &random));
  const std::string reason = FailureOf("flat_grey", FromFrames(frames));
  ExpectHas(reason, "no texture");
  ExpectHas(reason, "need >= 20");
}

TEST(PathologicalBurst, NoMotionHasNoParallax) {
  Burst burst = ToBurst(Generated());
  for (cv::Mat& frame : burst.gray) frame = burst.gray[0].clone();
  const std::string reason = FailureOf("no_motion", burst);
  ExpectHas(reason, "insufficient parallax: median track motion 0.00 px");
  ExpectHas(reason, "need >= 0.15 px");
}

TEST(PathologicalBurst, MotionFarBeyondSmallMotionLosesTheTracks) {
  // A pan of 100 px per frame on a 320 px image: no longer small motion.
  // (At 40 px per frame the first six frames keep 50 tracks and the two
  // that lose them are left out: a result, warned of as a relief the burst
  // cannot measure.)
  Burst burst = ToBurst(Generated());
  const cv::Mat reference = burst.gray[0];
  cv::Mat wide;
  cv::copyMakeBorder(reference, wide, 0, 0, 0, 100 * kFrames, cv::BORDER_WRAP);
  for (int i = 0; i < kFrames; ++i) burst.gray[i] = wide(cv::Rect(100 * i, 0, kWidth, kHeight));
  const std::string reason = FailureOf("large_motion", burst);
  ExpectHas(reason, "too few tracks");
  ExpectHas(reason, "motion too large");
  ExpectHas(reason, "need >= 20");
}

TEST(PathologicalBurst, TextureInOneCornerGivesTooFewTracks) {
  // A small textured patch in front of a flat wall: a handful of cells can hold
  // a corner, too few to separate rotation, translation and depth.
  Burst burst = ToBurst(Generated());
  for (cv::Mat& frame : burst.gray) {
    cv::Mat flat(frame.size(), CV_8UC1, cv::Scalar(90));
    frame(cv::Rect(20, 20, 48, 48)).copyTo(flat(cv::Rect(20, 20, 48, 48)));
    frame = flat;
  }
  const std::string reason = FailureOf("few_tracks", burst);
  ExpectHas(reason, "too few tracks");
  ExpectHas(reason, "need >= 20");
}

// A jolt in one frame (a 25 px smear across it): the tracker loses most
// tracks there. The frame is left out, said so, and the burst succeeds on the
// others; the result still has a pose for every frame given.
TEST(PathologicalBurst, AFrameTheTrackerLosesIsLeftOutNotTheBurst) {
  Burst burst = ToBurst(Generated());
  const int jolted = 5;
  cv::Mat smear = cv::Mat::ones(1, 25, CV_32F) / 25.0;
  cv::filter2D(burst.gray[jolted], burst.gray[jolted], -1, smear);
  PipelineOptions options;
  options.dense.planes = 32;
  PipelineOutput output = RunPipeline(burst, options);
  ASSERT_TRUE(output.result.ok) << output.result.error;
  const nlohmann::json& untracked = output.result.extra.at("untracked_frames");
  ASSERT_EQ(untracked.size(), 1u) << untracked.dump();
  EXPECT_EQ(untracked[0]["frame"], jolted);
  EXPECT_LT(untracked[0]["tracks_with"].get<int>(), untracked[0]["tracks_without"].get<int>() / 2);
  EXPECT_EQ(untracked[0]["pose"], "interpolated");
  ASSERT_EQ(output.result.poses.size(), static_cast<size_t>(kFrames));
  // The interpolated pose lies between its neighbours'.
  const Eigen::Vector3d before = output.result.poses[jolted - 1].Centre(),
                        after = output.result.poses[jolted + 1].Centre(),
                        between = output.result.poses[jolted].Centre();
  EXPECT_LT((between - 0.5 * (before + after)).norm(), 0.5 * (after - before).norm() + 1e-12);
  bool warned = false;
  for (const std::string& warning : output.result.warnings)
    warned = warned || warning.find("left out: the tracker lost") != std::string::npos;
  EXPECT_TRUE(warned);
  EXPECT_EQ(output.result.extra.at("sparse_detail").at("reached_per_frame").size(),
            static_cast<size_t>(kFrames));
  EXPECT_TRUE(output.result.extra.at("depth_verdict").contains("quality"));
}

// A repeat and a frame the tracker loses in one burst: each is left out for
// its own reason, and the frame that repeats a lost frame is listed with it.
TEST(PathologicalBurst, ARepeatOfALostFrameIsListedWithIt) {
  Burst burst = ToBurst(Generated());
  cv::filter2D(burst.gray[5], burst.gray[5], -1, cv::Mat::ones(1, 25, CV_32F) / 25.0);
  burst.gray[6] = burst.gray[5].clone();  // the driver handed out frame 5 twice
  burst.gray[2] = burst.gray[1].clone();
  PipelineOptions options;
  options.dense.planes = 32;
  const PipelineOutput output = RunPipeline(burst, options);
  ASSERT_TRUE(output.result.ok) << output.result.error;
  const nlohmann::json& repeated = output.result.extra.at("repeated_frames");
  ASSERT_EQ(repeated.size(), 2u) << repeated.dump();
  const nlohmann::json& untracked = output.result.extra.at("untracked_frames");
  ASSERT_EQ(untracked.size(), 2u) << untracked.dump();
  EXPECT_EQ(untracked[0]["frame"], 5);
  EXPECT_EQ(untracked[1]["frame"], 6);
  ASSERT_EQ(output.result.poses.size(), static_cast<size_t>(kFrames));
  // A repeat shows its original's pose, interpolated or not.
  EXPECT_TRUE(output.result.poses[6].R.isApprox(output.result.poses[5].R));
  EXPECT_TRUE(output.result.poses[2].T.isApprox(output.result.poses[1].T));
}

TEST(PathologicalBurst, AGoodBurstStillSucceeds) {
  PipelineOptions options;
  options.dense.planes = 32;
  const PipelineOutput output = RunPipeline(ToBurst(Generated()), options);
  EXPECT_TRUE(output.result.ok) << output.result.error;
  // A generated burst that tracks cleanly: its map is not suspect as a whole.
  EXPECT_NE(output.result.extra.at("depth_verdict").at("quality"), "unreliable")
      << output.result.extra.at("depth_verdict").dump();
}

}  // namespace
}  // namespace dfsm
