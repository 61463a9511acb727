// The sparse stage end to end on generated bursts with ground truth: rendered
// frames -> grided KLT -> rotations -> rank-1 -> self-calibrating bundle
// adjustment, scored with the metrics of Ha et al.
#include <gtest/gtest.h>

#include <string>

#include "core/pipeline/evaluation.h"
#include "core/sparse/sparse_reconstruction.h"
#include "core/synth/burst_synthesizer.h"

namespace dfsm {
namespace {

struct Case {
  int width, height, frames;
  uint64_t seed;
};

std::string Name(const ::testing::TestParamInfo<Case>& info) {
  return std::to_string(info.param.width) + "x" + std::to_string(info.param.height) + "_" +
         std::to_string(info.param.frames) + "frames_seed" + std::to_string(info.param.seed);
}

class SyntheticSparse : public ::testing::TestWithParam<Case> {};

// The acceptance bounds: Ceres CONVERGENCE, focal error <= 1 %,
// distortion error <= 0.5 px, mean rotation error <= 0.05 deg.
TEST_P(SyntheticSparse, RankOneAndBundleAdjustmentRecoverTheCamera) {
  const Case c = GetParam();
  SynthOptions synth;
  synth.width = c.width;
  synth.height = c.height;
  synth.frames = c.frames;
  synth.seed = c.seed;
  synth.supersampling = 2;
  const SynthBurst generated = SynthesizeBurst(synth);
  const Burst burst = ToBurst(generated);

  const SparseReconstruction sparse = ReconstructSparse(burst.gray, burst.reference());
  const SparseEvaluation score =
      EvaluateSparse(sparse.state.camera, sparse.state.poses, generated.truth);
  RecordProperty("focal_error_percent", std::to_string(score.focal_error_percent));
  RecordProperty("distortion_error_px", std::to_string(score.distortion_error_px));
  RecordProperty("iterations", sparse.bundle_adjustment.iterations);
  EXPECT_TRUE(sparse.bundle_adjustment.converged) << sparse.bundle_adjustment.termination;
  EXPECT_LE(sparse.bundle_adjustment.iterations, 25);
  EXPECT_LE(score.focal_error_percent, 1.0) << "f = " << sparse.state.camera.f;
  EXPECT_LE(score.distortion_error_px, 0.5);
  EXPECT_LE(score.mean_rotation_error_deg, 0.05);
  EXPECT_LT(sparse.bundle_adjustment.rms_reprojection_px, 0.3);
}

INSTANTIATE_TEST_SUITE_P(Bursts, SyntheticSparse,
                         ::testing::Values(Case{640, 480, 10, 1}, Case{640, 480, 15, 2},
                                           Case{1920, 1080, 10, 3}, Case{1920, 1080, 15, 4}),
                         Name);

}  // namespace
}  // namespace dfsm
