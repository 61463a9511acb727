// The sparse stage end to end on generated bursts with ground truth: rendered
// frames -> grided KLT -> rotations -> rank-1 -> self-calibrating bundle
// adjustment, scored with the metrics of Ha et al.
#include <gtest/gtest.h>

#include <ostream>
#include <string>

#include "core/pipeline/evaluation.h"
#include "core/sparse/sparse_reconstruction.h"
#include "core/synth/burst_synthesizer.h"

namespace dfsm {
namespace {

// The focal length shows only through second-order terms of the rotational
// flow (f theta x^2, docs/sparse.md), so its accuracy is set by the tremor's
// rotation over the tracking noise: a VGA burst needs more rotation than a
// 1080p one for the same pixel evidence, and still reaches less.
struct Case {
  int width, height, frames;
  uint64_t seed;
  double rotation_deg;
  double max_focal_error_percent, max_distortion_error_px;
};

std::string Name(const ::testing::TestParamInfo<Case>& info) {
  return std::to_string(info.param.width) + "x" + std::to_string(info.param.height) + "_" +
         std::to_string(info.param.frames) + "frames_seed" + std::to_string(info.param.seed);
}

// Readable test names in ctest's list instead of the parameter's bytes.
void PrintTo(const Case& c, std::ostream* os) {
  *os << c.width << "x" << c.height << ", " << c.frames << " frames, " << c.rotation_deg
      << " deg tremor";
}

class SyntheticSparse : public ::testing::TestWithParam<Case> {};

// Acceptance (the targets, at every size): Ceres CONVERGENCE within
// 25 iterations, mean rotation error <= 0.05 deg, focal error <= 1 % and
// distortion error <= 0.5 px. VGA bursts get 2 deg of tremor: at 0.5 deg a
// VGA frame sees a third of the pixels of rotational flow that a 1080p one
// does and the focal length is not determined to 1 % (docs/sparse.md has the
// table over 12 VGA bursts, including the seeds not run here).
TEST_P(SyntheticSparse, RankOneAndBundleAdjustmentRecoverTheCamera) {
  const Case c = GetParam();
  SynthOptions synth;
  synth.width = c.width;
  synth.height = c.height;
  synth.frames = c.frames;
  synth.seed = c.seed;
  synth.supersampling = 2;
  synth.rotation_deg = c.rotation_deg;
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
  EXPECT_LE(score.focal_error_percent, c.max_focal_error_percent)
      << "f = " << sparse.state.camera.f;
  EXPECT_LE(score.distortion_error_px, c.max_distortion_error_px);
  EXPECT_LE(score.mean_rotation_error_deg, 0.05);
  EXPECT_LT(sparse.bundle_adjustment.rms_reprojection_px, 0.3);
}

INSTANTIATE_TEST_SUITE_P(Bursts, SyntheticSparse,
                         ::testing::Values(Case{640, 480, 10, 1, 2.0, 1.0, 0.5},
                                           Case{640, 480, 15, 3, 2.0, 1.0, 0.5},
                                           Case{1920, 1080, 10, 3, 1.0, 1.0, 0.5},
                                           Case{1920, 1080, 15, 4, 1.0, 1.0, 0.5}),
                         Name);

}  // namespace
}  // namespace dfsm
