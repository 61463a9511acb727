// The whole method on real webcam frames against real depth: the 10-frame
// windows of TUM RGB-D fr1/xyz (../shared/data/tum_fr1_xyz) that
// bench/tum_benchmark reports (docs/dense.md, "TUM fr1/xyz"), scored against
// the Kinect's depth after one global scale beside a constant-depth guess.
// The bounds hold the issue's criterion, "clearly better than a constant
// depth", with room for the machine-to-machine drift of the tracks.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "bench/tum_sequence.h"
#include "core/export/calibration_import.h"
#include "core/pipeline/evaluation.h"
#include "core/pipeline/pipeline.h"
#include "tests/test_data.h"

namespace dfsm {
namespace {

constexpr int kFrames = 10;
constexpr int kStep = 3;

struct WindowScore {
  int first = 0;
  DepthEvaluation measured, filled, constant;
};

// Every window of the sequence through the pipeline, with the published
// calibration held fixed (`known`) or self-calibrated.
std::vector<WindowScore> ScoreWindows(const TumSequence& sequence, bool known) {
  const std::string calibration_file = TumFreiburg1CalibrationFile();
  PipelineOptions options;
  if (known) {
    KnownCalibration fixed;
    fixed.camera = ReadCalibrationFile(calibration_file, 640, 480).camera;
    fixed.mode = KnownCalibrationMode::kFixed;
    fixed.source = calibration_file;
    options.sparse.known = fixed;
  }
  std::vector<WindowScore> scores;
  for (int first = 0; first + kFrames <= sequence.frames(); first += kStep) {
    const Burst burst = sequence.Window(first, kFrames);
    const cv::Mat truth = sequence.ReferenceDepth(first, kFrames);
    const PipelineOutput output = RunPipeline(burst, options);
    EXPECT_TRUE(output.result.ok) << "window " << first << ": " << output.result.error;
    if (!output.result.ok || !output.dense) continue;
    WindowScore score;
    score.first = first;
    score.measured = EvaluateDepth(output.dense->depth, truth, cv::Mat());
    score.filled = EvaluateDepth(output.dense->depth_filled, truth, cv::Mat());
    score.constant =
        EvaluateDepth(cv::Mat(truth.size(), CV_32FC1, cv::Scalar(1.0f)), truth, cv::Mat());
    scores.push_back(score);
  }
  return scores;
}

#define DFSM_REQUIRE_TUM(sequence)                                    \
  if ((sequence).empty())                                             \
  GTEST_SKIP() << "TUM fr1/xyz not found at " << (sequence).dataset() \
               << " (rgb.txt, depth.txt; it lives in ../shared/data beside the repository)"

// Self-calibrated, every window. Measured 2026-11-27: AbsRel 3.6-5.0 % on the
// pixels with a depth (24-48 % of the Kinect's), filled 5.0-7.8 %, against
// 15.1-18.2 % for a constant depth. Window 18-27 reads 4.7 % since the
// adjustment restarts from several readouts (it was 15.9 %: a readout that
// trades against a tilt of the scene, docs/sparse.md).
TEST(TumPipeline, SelfCalibratedEveryWindowIsClearlyBetterThanAConstantDepth) {
  const TumSequence sequence(testing::SharedData("tum_fr1_xyz").string());
  DFSM_REQUIRE_TUM(sequence);
  const std::vector<WindowScore> scores = ScoreWindows(sequence, false);
  EXPECT_EQ(scores.size(), 10u);
  for (const WindowScore& s : scores) {
    EXPECT_LT(s.measured.abs_rel, 0.5 * s.constant.abs_rel) << "window " << s.first;
    EXPECT_LT(s.filled.abs_rel, 0.7 * s.constant.abs_rel) << "window " << s.first;
    EXPECT_GT(s.measured.coverage, 0.2) << "window " << s.first;
    EXPECT_EQ(s.filled.coverage, 1.0) << "window " << s.first;
  }
}

// The published calibration held fixed. Measured 2026-11-27: median AbsRel
// 4.2 % measured, 6.5 % filled (within 25 %: 95.9 %). Nine of the ten
// windows are clearly better than a constant depth; window 18-27 is not
// (15.7 % against 15.1 %: with f held, every readout start returns to the
// same minimum, docs/sparse.md), which is why this test counts windows.
TEST(TumPipeline, PublishedCalibrationMediansAndWindowsBetterThanAConstantDepth) {
  const TumSequence sequence(testing::SharedData("tum_fr1_xyz").string());
  DFSM_REQUIRE_TUM(sequence);
  const std::vector<WindowScore> scores = ScoreWindows(sequence, true);
  ASSERT_EQ(scores.size(), 10u);
  std::vector<double> measured, filled, filled_within_25;
  int clearly_better = 0;
  for (const WindowScore& s : scores) {
    measured.push_back(s.measured.abs_rel);
    filled.push_back(s.filled.abs_rel);
    filled_within_25.push_back(s.filled.within_25_percent);
    clearly_better += s.measured.abs_rel < 0.5 * s.constant.abs_rel;
  }
  EXPECT_LT(WindowMedian(measured), 0.05);
  EXPECT_LT(WindowMedian(filled), 0.075);
  EXPECT_GT(WindowMedian(filled_within_25), 0.93);
  EXPECT_GE(clearly_better, 9);
}

}  // namespace
}  // namespace dfsm
