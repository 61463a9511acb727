// The whole method on real webcam frames against real depth: the 10-frame
// windows of TUM RGB-D fr1/xyz (../shared/data/tum_fr1_xyz) that
// bench/tum_benchmark reports (docs/experiments/210-tum-fr1-xyz.md), scored against
// the Kinect's depth after one global scale beside a constant-depth guess.
// The bounds hold the issue's criterion, "clearly better than a constant
// depth", with room for the machine-to-machine drift of the tracks.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/tum_sequence.h"
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
  bool confirmed = false;  // the result's depth_check
};

// The pipeline's options with the published calibration held fixed
// (`known`, scaled to the sequence's frames), or self-calibrating.
PipelineOptions TumOptions(const TumSequence& sequence, bool known) {
  PipelineOptions options;
  if (!known) return options;
  const std::string calibration_file = TumFreiburg1CalibrationFile();
  const ImportedCalibration imported = sequence.ReadCalibration(calibration_file);
  KnownCalibration fixed;
  fixed.camera = imported.camera;
  fixed.lens = imported.lens;  // the frames resampled from the published lens
  fixed.mode = KnownCalibrationMode::kFixed;
  fixed.source = calibration_file;
  options.sparse.known = fixed;
  return options;
}

// A constant depth against the truth: the baseline a map must beat.
DepthEvaluation ConstantDepth(const cv::Mat& truth) {
  return EvaluateDepth(cv::Mat(truth.size(), CV_32FC1, cv::Scalar(1.0f)), truth, cv::Mat());
}

// Every window of the sequence through the pipeline (TumOptions).
std::vector<WindowScore> ScoreWindows(const TumSequence& sequence, bool known) {
  const PipelineOptions options = TumOptions(sequence, known);
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
    score.constant = ConstantDepth(truth);
    score.confirmed = output.result.extra.at("depth_check").at("confirmed").get<bool>();
    scores.push_back(score);
  }
  return scores;
}

// The criterion: the measured map at most half as far off as a
// constant depth.
bool ClearlyBetter(const WindowScore& s) { return s.measured.abs_rel < 0.5 * s.constant.abs_rel; }

// A map that is not clearly better than a constant depth must not say
// `confirmed`: the result has to tell the user it cannot vouch for it.
void ExpectNoFalseConfirmation(const std::vector<WindowScore>& scores) {
  for (const WindowScore& s : scores) {
    if (ClearlyBetter(s)) continue;
    EXPECT_FALSE(s.confirmed) << "window " << s.first << ": " << 100.0 * s.measured.abs_rel
                              << " % against " << 100.0 * s.constant.abs_rel
                              << " % for a constant depth";
  }
}

// A warning about the depth map (result.json's warnings that start "depth "):
// what a client reads where the map cannot be vouched for.
bool HasDepthWarning(const Result& result) {
  return std::any_of(result.warnings.begin(), result.warnings.end(),
                     [](const std::string& w) { return w.rfind("depth ", 0) == 0; });
}

#define DFSM_REQUIRE_TUM(sequence)                                    \
  if ((sequence).empty())                                             \
  GTEST_SKIP() << "TUM fr1/xyz not found at " << (sequence).dataset() \
               << " (rgb.txt, depth.txt; it lives in ../shared/data beside the repository)"

// Self-calibrated, every window. Measured 2026-11-27: AbsRel 3.6-5.0 % on the
// pixels with a depth (24-48 % of the Kinect's), filled 5.0-7.8 %, against
// 15.1-18.2 % for a constant depth. Window 18-27 reads 4.7 % since the
// adjustment restarts from several readouts (it was 15.9 %: a readout that
// trades against a tilt of the scene, docs/experiments/115-readout-restarts.md).
TEST(TumPipeline, SelfCalibratedEveryWindowIsClearlyBetterThanAConstantDepth) {
  const TumSequence sequence(testing::SharedData("tum_fr1_xyz").string());
  DFSM_REQUIRE_TUM(sequence);
  const std::vector<WindowScore> scores = ScoreWindows(sequence, false);
  EXPECT_EQ(scores.size(), 10u);
  for (const WindowScore& s : scores) {
    EXPECT_TRUE(ClearlyBetter(s)) << "window " << s.first << ": " << s.measured.abs_rel
                                  << " against " << s.constant.abs_rel;
    EXPECT_LT(s.filled.abs_rel, 0.7 * s.constant.abs_rel) << "window " << s.first;
    EXPECT_GT(s.measured.coverage, 0.2) << "window " << s.first;
    EXPECT_EQ(s.filled.coverage, 1.0) << "window " << s.first;
  }
  ExpectNoFalseConfirmation(scores);
}

// The published calibration held fixed. Measured 2026-11-29 (eighteenth
// session): median AbsRel 3.9 % measured, 6.0 % filled (within 25 %:
// 96.7 %), every window clearly better than a constant depth. Window 18-27
// reads 3.8 % since the naive start is probed beside the rank-1 one; it was
// 14.9 % against 15.1 % for a constant depth: the rank-1 start settled in a
// minimum with a flattened relief (docs/experiments/129-naive-probe.md).
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
    clearly_better += ClearlyBetter(s);
  }
  EXPECT_LT(WindowMedian(measured), 0.05);
  EXPECT_LT(WindowMedian(filled), 0.075);
  EXPECT_GT(WindowMedian(filled_within_25), 0.93);
  EXPECT_EQ(clearly_better, 10);
  ExpectNoFalseConfirmation(scores);
}

// The same windows at 320x240 (TumSequence's downscale 2: the frames
// area-averaged, the Kinect's depth in 2x2 blocks, the calibration scaled).
// Measured 2026-11-29 (bench/tum_benchmark --downscale 2): median AbsRel
// 4.5 % measured (coverage 51-79 %), 6.2 % filled; window 18-27 is 14.6 %
// against 15.0 % for a constant depth (docs/experiments/233-tum-320x240.md). It
// said `confirmed` until the naive probe: the burst calibrated
// alone now finds the minimum the known camera misses, and the known
// calibration "does not fit" (0.28 px RMS against 0.21).
TEST(TumPipeline, At320x240ThePublishedCalibrationMediansHold) {
  const TumSequence sequence(testing::SharedData("tum_fr1_xyz").string(), 2);
  DFSM_REQUIRE_TUM(sequence);
  const std::vector<WindowScore> scores = ScoreWindows(sequence, true);
  ASSERT_EQ(scores.size(), 10u);
  std::vector<double> measured, filled;
  int clearly_better = 0;
  for (const WindowScore& s : scores) {
    measured.push_back(s.measured.abs_rel);
    filled.push_back(s.filled.abs_rel);
    clearly_better += ClearlyBetter(s);
    EXPECT_GT(s.measured.coverage, 0.4) << "window " << s.first;
  }
  EXPECT_LT(WindowMedian(measured), 0.055);
  EXPECT_LT(WindowMedian(filled), 0.075);
  EXPECT_GE(clearly_better, 9);
  ExpectNoFalseConfirmation(scores);
}

// Self-calibrated at 320x240. Measured 2026-11-29 (bench/tum_benchmark
// --downscale 2): median AbsRel 4.4 % measured, 5.8 % filled, every window
// clearly better than a constant depth. Window 18-27 reads 5.8 % since the
// naive probe; it was 15.1 % and said `confirmed`
// (docs/experiments/129-naive-probe.md).
TEST(TumPipeline, At320x240SelfCalibratedEveryWindowIsClearlyBetterThanAConstantDepth) {
  const TumSequence sequence(testing::SharedData("tum_fr1_xyz").string(), 2);
  DFSM_REQUIRE_TUM(sequence);
  const std::vector<WindowScore> scores = ScoreWindows(sequence, false);
  ASSERT_EQ(scores.size(), 10u);
  for (const WindowScore& s : scores)
    EXPECT_TRUE(ClearlyBetter(s)) << "window " << s.first << ": " << s.measured.abs_rel
                                  << " against " << s.constant.abs_rel;
  ExpectNoFalseConfirmation(scores);
}

// fr1/rpy's window that turns most (frames 13-22 of ../shared/data/tum_fr1_rpy,
// the shared window 97: 5.9 deg over ten frames): five of its frames blur
// away most tracks. They are left out with their reason and the burst is
// processed from the five that track (40 tracks); its depth, 336 % AbsRel
// self-calibrated and 228 % with the published camera against a constant's
// 23 % (measured 2026-12-04), must say that it cannot be vouched for
// (docs/experiments/018-frames-kept-above-the-track-floor.md). With the
// published camera the frames' own angular velocities leave 15 tracks in
// front of the camera on the five frames; the rows go back to the line
// between frame poses and the result says so
// (docs/experiments/024-velocity-jacobian-and-known-fit.md).
TEST(TumRpy, FramesThatBlurAwayTheTracksAreLeftOutNotTheBurst) {
  const TumSequence sequence(testing::SharedData("tum_fr1_rpy").string());
  if (sequence.empty())
    GTEST_SKIP() << "TUM fr1/rpy not found at " << sequence.dataset()
                 << " (rgb.txt, depth.txt; it lives in ../shared/data beside the repository)";
  const cv::Mat truth = sequence.ReferenceDepth(13, kFrames);
  for (const bool known : {false, true}) {
    SCOPED_TRACE(known ? "published calibration" : "self-calibrated");
    const PipelineOutput output =
        RunPipeline(sequence.Window(13, kFrames), TumOptions(sequence, known));
    ASSERT_TRUE(output.result.ok && output.dense) << output.result.error;
    const nlohmann::json& untracked = output.result.extra.at("untracked_frames");
    EXPECT_GE(untracked.size(), 1u);
    EXPECT_LE(untracked.size(), 5u);  // at least half the frames stay
    for (const nlohmann::json& frame : untracked) {
      EXPECT_EQ(frame.at("pose"), "interpolated");
      EXPECT_LT(frame.at("tracks_with").get<int>(), frame.at("tracks_without").get<int>());
    }
    if (known) {
      EXPECT_EQ(output.result.calibration_detail.at("rolling_shutter").at("row_path"), "line");
      EXPECT_TRUE(std::any_of(output.result.warnings.begin(), output.result.warnings.end(),
                              [](const std::string& warning) {
                                return warning.find("rows on the line between frame poses") !=
                                       std::string::npos;
                              }));
    }
    WindowScore score;
    score.measured = EvaluateDepth(output.dense->depth, truth, cv::Mat());
    score.constant = ConstantDepth(truth);
    if (!ClearlyBetter(score)) {
      EXPECT_NE(output.result.extra.at("depth_verdict").at("quality"), "confirmed")
          << 100.0 * score.measured.abs_rel << " % against " << 100.0 * score.constant.abs_rel
          << " %";
      EXPECT_FALSE(output.result.extra.at("depth_check").at("confirmed").get<bool>());
      EXPECT_TRUE(HasDepthWarning(output.result));
    }
  }
}

// Every window of fr1/rpy's twelve-frame pieces, the shared ones and those
// one frame earlier and later (24 windows; the sequence's other windows
// score like these, docs/experiments/022-windows-one-frame-apart.md), with
// the published calibration and self-calibrated: every window yields a
// result (issue 55), and a map worse than a constant depth is neither
// `confirmed` nor without a depth warning. Measured 2026-12-05: 24 of 24;
// 14-23, whose frames 0 and 7-9 blur away the tracks, from five frames and
// 40 tracks, `unreliable` (docs/experiments/029-room-above-the-track-floor.md).
TEST(TumRpy, NoMapWorseThanAConstantDepthIsVouchedFor) {
  const TumSequence sequence(testing::SharedData("tum_fr1_rpy").string());
  if (sequence.empty())
    GTEST_SKIP() << "TUM fr1/rpy not found at " << sequence.dataset()
                 << " (rgb.txt, depth.txt; it lives in ../shared/data beside the repository)";
  constexpr int kPiece = 12;  // frames per piece: the window and one on each side
  for (const bool known : {true, false}) {
    const PipelineOptions options = TumOptions(sequence, known);
    for (int first = 0; first + kFrames <= sequence.frames(); ++first) {
      if (first % kPiece + kFrames > kPiece) continue;  // across two pieces
      const std::string window = std::to_string(first) + (known ? " (published)" : " (self)");
      const PipelineOutput output = RunPipeline(sequence.Window(first, kFrames), options);
      if (!output.result.ok || !output.dense) {
        ADD_FAILURE() << "window " << window << ": " << output.result.error;
        continue;
      }
      const cv::Mat truth = sequence.ReferenceDepth(first, kFrames);
      const double measured = EvaluateDepth(output.dense->depth, truth, cv::Mat()).abs_rel;
      const double constant = ConstantDepth(truth).abs_rel;
      if (measured < constant) continue;
      const std::string scored = "window " + window + ": " + std::to_string(100.0 * measured) +
                                 " % against " + std::to_string(100.0 * constant);
      EXPECT_NE(output.result.extra.at("depth_verdict").at("quality"), "confirmed") << scored;
      EXPECT_TRUE(HasDepthWarning(output.result)) << scored;
    }
  }
}

// What the downscale serves lines up: the frames are the full ones
// area-averaged, a depth pixel is the mean of its whole block, close in depth,
// and none across a depth edge.
TEST(TumSequence, DownscaledFramesAndDepthLineUp) {
  const std::string dataset = testing::SharedData("tum_fr1_xyz").string();
  const TumSequence full(dataset), half(dataset, 2);
  DFSM_REQUIRE_TUM(full);
  const cv::Size reduced(half.width(), half.height());
  EXPECT_EQ(reduced, cv::Size(320, 240));

  const Burst fine_burst = full.Window(0, 3), burst = half.Window(0, 3);
  EXPECT_EQ(burst.width(), reduced.width);
  EXPECT_EQ(burst.height(), reduced.height);
  ASSERT_EQ(burst.size(), 3);
  cv::Mat expected;
  cv::resize(fine_burst.reference_color, expected, reduced, 0.0, 0.0, cv::INTER_AREA);
  EXPECT_EQ(cv::norm(burst.reference_color, expected, cv::NORM_INF), 0.0);
  EXPECT_EQ(burst.gray[0].size(), reduced);

  const cv::Mat fine = full.ReferenceDepth(0, 3), coarse = half.ReferenceDepth(0, 3);
  ASSERT_EQ(coarse.size(), reduced);
  int kept = 0;
  for (int y = 0; y < coarse.rows; ++y)
    for (int x = 0; x < coarse.cols; ++x) {
      const cv::Mat block = fine(cv::Rect(2 * x, 2 * y, 2, 2));
      double lowest, highest;
      cv::minMaxLoc(block, &lowest, &highest);
      const float value = coarse.at<float>(y, x);
      if (lowest <= 0.0 || highest > 1.1 * lowest) {
        EXPECT_EQ(value, 0.0f) << x << ", " << y;  // a hole or an edge in the block
      } else if (highest < 1.04 * lowest) {
        EXPECT_NEAR(value, cv::mean(block)[0], 1e-5) << x << ", " << y;  // well within
        ++kept;
      }
    }
  EXPECT_GT(kept, reduced.area() / 2);  // most of the Kinect's view survives
}

// The downscale is checked, and the calibration follows it (no data needed).
TEST(TumSequence, DownscaleIsCheckedAndScalesTheCalibration) {
  const std::string nowhere = "/nonexistent/tum";
  EXPECT_THROW(TumSequence(nowhere, 3), std::invalid_argument);
  EXPECT_THROW(TumSequence(nowhere, 0), std::invalid_argument);
  EXPECT_THROW(TumSequence(nowhere, TumSequence::kMaxDownscale * 2), std::invalid_argument);

  CameraModel camera;
  camera.width = TumSequence::kWidth;
  camera.height = TumSequence::kHeight;
  camera.f = 516.9;
  camera.cx = 318.6;
  camera.cy = 255.3;
  camera.k1 = -0.12;
  camera.k2 = 0.1;
  const TumSequence same(nowhere), half(nowhere, 2);
  const CameraModel unchanged = same.Scaled(camera);
  EXPECT_EQ(unchanged.f, camera.f);
  EXPECT_EQ(unchanged.cx, camera.cx);
  EXPECT_EQ(unchanged.cy, camera.cy);
  const CameraModel scaled = half.Scaled(camera);
  EXPECT_EQ(scaled.width, 320);
  EXPECT_EQ(scaled.height, 240);
  EXPECT_DOUBLE_EQ(scaled.f, 258.45);
  // Block centres: captured x at the reduced (x + 0.5) / 2 - 0.5.
  EXPECT_DOUBLE_EQ(scaled.cx, 159.05);
  EXPECT_DOUBLE_EQ(scaled.cy, 127.4);
  EXPECT_EQ(scaled.k1, camera.k1);
  EXPECT_EQ(scaled.k2, camera.k2);
  camera.width = 320;
  EXPECT_THROW(half.Scaled(camera), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
