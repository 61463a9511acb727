// The whole method on generated bursts: sparse + dense, scored against the
// ground truth, and the dfsm-result/1 directory a user receives.
#include "core/pipeline/pipeline.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/io/depth_tiff.h"
#include "core/io/file_util.h"
#include "core/pipeline/evaluation.h"
#include "core/synth/burst_synthesizer.h"

namespace dfsm {
namespace {

SynthBurst SmallBurst(int jpeg_quality = 0) {
  SynthOptions options;
  options.width = 640;
  options.height = 480;
  options.frames = 10;
  options.supersampling = 2;
  options.jpeg_quality = jpeg_quality;
  return SynthesizeBurst(options);
}

TEST(Pipeline, DepthMatchesTheGroundTruth) {
  for (const int jpeg : {0, 90}) {
    const SynthBurst generated = SmallBurst(jpeg);
    const Burst burst = ToBurst(generated);
    const PipelineOutput output = RunPipeline(burst, {});
    ASSERT_TRUE(output.result.ok) << output.result.error;
    ASSERT_TRUE(output.dense.has_value());
    const DepthEvaluation score = EvaluateDepth(output.dense->depth, generated.truth.depth,
                                                TexturedMask(burst.gray[burst.reference()]));
    EXPECT_LT(score.abs_rel, 0.04) << "jpeg " << jpeg;
    EXPECT_GT(score.within_5_percent, 0.85) << "jpeg " << jpeg;
    EXPECT_GT(score.coverage, 0.80) << "jpeg " << jpeg;
  }
}

TEST(Pipeline, WritesACompleteResultDirectory) {
  const SynthBurst generated = SmallBurst();
  const Burst burst = ToBurst(generated);
  PipelineOutput output = RunPipeline(burst, {});
  ASSERT_TRUE(output.result.ok) << output.result.error;
  const auto dir = std::filesystem::temp_directory_path() / "dfsm_pipeline_test_result";
  std::filesystem::remove_all(dir);
  WritePipelineOutputs(dir, burst, &output);

  const auto result = nlohmann::json::parse(ReadFileToString(dir / "result.json"));
  EXPECT_EQ(result["format"], "dfsm-result/1");
  EXPECT_EQ(result["status"], "ok");
  EXPECT_EQ(result["calibration"]["distortion_model"], "ha2016-d2u");
  EXPECT_EQ(result["poses"].size(), 10u);
  EXPECT_EQ(result["depth"]["file"], "depth.tiff");
  EXPECT_EQ(result["depth"]["planes"], 128);
  for (const char* stage : {"features", "rotation", "rank1", "bundle_adjustment", "dense", "total"})
    EXPECT_TRUE(result["timings_ms"].contains(stage)) << stage;
  for (const char* file : {"depth.tiff", "depth.png", "confidence.png", "preview.png", "points.ply",
                           "sparse_points.ply", "calibration.json", "calibration.yaml"})
    EXPECT_TRUE(std::filesystem::is_regular_file(dir / file)) << file;

  const cv::Mat depth = ReadDepthTiff(dir / "depth.tiff");
  EXPECT_EQ(depth.size(), cv::Size(640, 480));
  EXPECT_EQ(cv::imread((dir / "depth.png").string(), cv::IMREAD_UNCHANGED).type(), CV_16UC1);
  EXPECT_EQ(cv::imread((dir / "preview.png").string()).cols, 2 * 640);
  std::filesystem::remove_all(dir);
}

TEST(Pipeline, AStillBurstFailsWithAReasonAndAResultFile) {
  const SynthBurst generated = SmallBurst();
  Burst burst = ToBurst(generated);
  for (cv::Mat& frame : burst.gray) frame = burst.gray[0].clone();
  PipelineOutput output = RunPipeline(burst, {});
  ASSERT_FALSE(output.result.ok);
  EXPECT_NE(output.result.error.find("insufficient parallax"), std::string::npos)
      << output.result.error;
  const auto dir = std::filesystem::temp_directory_path() / "dfsm_pipeline_test_failed";
  std::filesystem::remove_all(dir);
  WritePipelineOutputs(dir, burst, &output);
  const auto result = nlohmann::json::parse(ReadFileToString(dir / "result.json"));
  EXPECT_EQ(result["status"], "failed");
  EXPECT_FALSE(std::filesystem::exists(dir / "depth.tiff"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dfsm
