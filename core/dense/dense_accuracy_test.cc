// Accuracy of the dense stage on generated bursts (core/synth) with the true
// camera and poses: the project's targets (see
// docs/experiments/201-accuracy-true-geometry.md for the measured table).
// Renders 1080p bursts, so it carries the ctest label `accuracy` and is not
// part of the default run.
#include <gtest/gtest.h>

#include <string>

#include "core/dense/dense_depth.h"
#include "core/pipeline/evaluation.h"
#include "core/synth/burst_synthesizer.h"

namespace dfsm {
namespace {

struct Case {
  int width, height, frames, jpeg_quality;
  double max_abs_rel, min_within_5, min_coverage;
  double max_filled_abs_rel;  // depth_filled.tiff, every textured pixel
};

class DenseAccuracyTest : public ::testing::TestWithParam<Case> {};

TEST_P(DenseAccuracyTest, MeetsTheBoundsWithTruePoses) {
  const Case c = GetParam();
  SynthOptions options;
  options.width = c.width;
  options.height = c.height;
  options.frames = c.frames;
  options.jpeg_quality = c.jpeg_quality;
  const SynthBurst synth = SynthesizeBurst(options);
  const std::vector<double> sparse = SparseInverseDepthsFromTruth(synth.truth);
  const cv::Mat& truth = synth.truth.depth;
  const Burst burst = ToBurst(synth);
  const DenseDepth dense = ComputeDenseDepth(burst, synth.truth.camera, synth.truth.poses, sparse);
  const DepthEvaluation e =
      EvaluateDepth(dense.depth, truth, TexturedMask(burst.gray[burst.reference()]));
  EXPECT_NEAR(e.scale, 1.0, 0.01);
  EXPECT_LE(e.abs_rel, c.max_abs_rel);
  EXPECT_GE(e.within_5_percent, c.min_within_5);
  EXPECT_GE(e.coverage, c.min_coverage);
  RecordProperty("abs_rel", std::to_string(e.abs_rel));
  RecordProperty("within_5_percent", std::to_string(e.within_5_percent));
  RecordProperty("coverage", std::to_string(e.coverage));
  const DepthEvaluation f =
      EvaluateDepth(dense.depth_filled, truth, TexturedMask(burst.gray[burst.reference()]));
  EXPECT_LE(f.abs_rel, c.max_filled_abs_rel);
  EXPECT_GE(f.coverage, 0.999);
  RecordProperty("filled_abs_rel", std::to_string(f.abs_rel));
  RecordProperty("filled_within_5_percent", std::to_string(f.within_5_percent));
  RecordProperty("filled_coverage", std::to_string(f.coverage));
}

INSTANTIATE_TEST_SUITE_P(Synth, DenseAccuracyTest,
                         ::testing::Values(
                             // 640x480: regression bounds, not the 2 % target. Since the
                             // dense stage high-passes its frames
                             // (docs/experiments/218-high-passed-frames.md) these ideal
                             // bursts measure 2.52 % / 92.9 % / 94.1 % without JPEG, 3.06 %
                             // / 91.0 % with q90 at 10 frames, 3.08 % / 90.9 % at 15 (they
                             // had 1.03-1.63 % before it; real footage is what the
                             // high-pass is for); with the seed prior
                             // 2.42 / 93.0 / 94.4, 2.83 / 91.4, 2.77 / 92.0 %. Since the
                             // breaks among the raw winners
                             // (docs/experiments/224-breaks-among-raw-winners.md): 1.73 /
                             // 95.7 / 90.0 %, 2.09 / 94.3 / 89.7 %, 2.07 / 94.8 / 89.8 %;
                             // filled 2.60, 3.04, 3.01 %.
                             Case{640, 480, 10, 0, 0.03, 0.91, 0.87, 0.03},
                             Case{640, 480, 10, 90, 0.035, 0.89, 0.87, 0.035},
                             Case{640, 480, 15, 90, 0.035, 0.89, 0.87, 0.035},
                             // 1080p: the targets (measured 0.99-1.13 %, 96.8-96.9 %,
                             // 90.2-90.5 %: the coverage 0.2 points above its bound since
                             // the photo-consistency outliers; with the seed prior
                             // 0.93-1.04 %, 97.6 %, 90.2-90.5 %; since the breaks among
                             // the raw winners 0.81-0.91 %, 98.0 %, 89.3-89.6 %, and every
                             // pixel (the 98 % coverage) filled at 1.71-1.86 %).
                             Case{1920, 1080, 10, 0, 0.02, 0.95, 0.87, 0.02},
                             Case{1920, 1080, 10, 90, 0.02, 0.95, 0.87, 0.02},
                             Case{1920, 1080, 15, 90, 0.02, 0.95, 0.87, 0.02}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           const Case& c = info.param;
                           return std::to_string(c.width) + "x" + std::to_string(c.height) + "_" +
                                  std::to_string(c.frames) + "frames_jpeg" +
                                  std::to_string(c.jpeg_quality);
                         });

}  // namespace
}  // namespace dfsm
