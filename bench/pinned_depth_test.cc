#include "bench/pinned_depth.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "core/synth/burst_synthesizer.h"

namespace dfsm {
namespace {

struct Reconstructed {
  SynthBurst synth;
  Burst burst;
  PipelineOptions options;
  SparseReconstruction sparse;
};

// A VGA burst of the generator, its own camera held as a known calibration.
Reconstructed Reconstruct() {
  SynthOptions synth;
  synth.width = 640;
  synth.height = 480;
  synth.rotation_deg = 1.0;
  synth.seed = 7;
  Reconstructed out{SynthesizeBurst(synth), {}, {}, {}};
  out.burst = ToBurst(out.synth);
  KnownCalibration known;
  known.camera = out.synth.truth.camera;
  known.mode = KnownCalibrationMode::kFixed;
  out.options.sparse.known = known;
  out.sparse = ReconstructSparseStage(out.burst, out.options);
  return out;
}

// On a generated burst the true depths fit the tracks nearly as well as the
// tracks' own minimum (the model is the renderer's), the dense stage over
// the geometry pinned to them is as good as over the stage's own or better,
// and the camera freed with them held stays the true one.
TEST(PinnedDepth, TheTruthFitsAGeneratedBurst) {
  const Reconstructed r = Reconstruct();
  const std::optional<PinnedDepth> pinned = PinDepthToTruth(
      r.burst, r.synth.truth.depth, cv::Mat(), r.sparse, r.options.sparse, r.options.dense);
  ASSERT_TRUE(pinned);
  EXPECT_GE(pinned->tracks(), 50);
  EXPECT_LT(pinned->pinned_rms_px, 0.15);
  EXPECT_LT(pinned->pinned_median_px, 1.5 * pinned->free_median_px);
  EXPECT_LT(pinned->pinned_depth.abs_rel, 0.04);
  EXPECT_LE(pinned->pinned_depth.abs_rel, pinned->free_depth.abs_rel + 0.005);
  // The held depths are the truth's, up to one scale.
  const FeatureTracks& tracks = r.sparse.tracks;
  double ratio = 0.0;
  int checked = 0;
  for (int j = 0; j < tracks.num_tracks(); ++j) {
    if (!pinned->pinned_tracks[j]) continue;
    const Eigen::Vector2d p = tracks.pixels[tracks.reference].col(j);
    const double z = r.synth.truth.depth.at<float>(static_cast<int>(std::lround(p.y())),
                                                   static_cast<int>(std::lround(p.x())));
    const double scale = pinned->pinned.inverse_depths[j] * z;
    if (checked++ == 0) ratio = scale;
    EXPECT_NEAR(scale / ratio, 1.0, 1e-9) << "track " << j;
  }
  EXPECT_EQ(checked, pinned->tracks());
  // Freed with the depths held, the camera stays near the true one.
  EXPECT_NEAR(pinned->camera_at_truth.camera.f / r.synth.truth.camera.f, 1.0, 0.03);
  EXPECT_EQ(pinned->camera_at_truth.inverse_depths, pinned->pinned.inverse_depths);
  const nlohmann::json json = ToJson(*pinned);
  EXPECT_EQ(json.at("tracks").get<int>(), pinned->tracks());
  EXPECT_DOUBLE_EQ(json.at("camera_at_truth").at("f").get<double>(),
                   pinned->camera_at_truth.camera.f);
  EXPECT_DOUBLE_EQ(json.at("pinned_depth").at("abs_rel").get<double>(),
                   pinned->pinned_depth.abs_rel);
  EXPECT_DOUBLE_EQ(json.at("parallax_range_px").get<double>(), pinned->parallax_range_px);
  // The true depths leave no misfit across the parallax beyond the tracks'
  // own (the generator's model is the adjustment's).
  EXPECT_LT(pinned->pinned_split.across_px, pinned->free_split.across_px + 0.02);
  EXPECT_DOUBLE_EQ(json.at("pinned_split").at("across_px").get<double>(),
                   pinned->pinned_split.across_px);
}

// A wrong depth moves a track's observations along their parallax only: the
// split gives the error it adds to `along` and leaves `across` as it was.
TEST(PinnedDepth, SplitByParallaxPutsADepthErrorAlong) {
  const Reconstructed r = Reconstruct();
  const FeatureTracks& tracks = r.sparse.tracks;
  const ParallaxSplit own = SplitByParallax(tracks, r.sparse.inliers, r.sparse.state);
  ASSERT_GT(own.along_px, 0.0);
  ASSERT_GT(own.across_px, 0.0);
  SparseState wrong = r.sparse.state;
  for (size_t j = 0; j < wrong.inverse_depths.size(); ++j)
    wrong.inverse_depths[j] *= j % 2 ? 1.1 : 0.9;
  const ParallaxSplit split = SplitByParallax(tracks, r.sparse.inliers, wrong);
  EXPECT_GT(split.along_px, 3.0 * own.along_px);
  EXPECT_NEAR(split.across_px, own.across_px, 0.1 * own.across_px);
}

// The parallax range of the pinned geometry is the truth's: f x the farthest
// camera centre off the reference's axis x the truth's inverse-depth spread,
// each in the truth's own metres, which the pinned scale cancels.
TEST(PinnedDepth, ParallaxRangeIsTheTruths) {
  const Reconstructed r = Reconstruct();
  const std::optional<PinnedDepth> pinned = PinDepthToTruth(
      r.burst, r.synth.truth.depth, cv::Mat(), r.sparse, r.options.sparse, r.options.dense);
  ASSERT_TRUE(pinned);
  std::vector<double> inverse;
  for (int y = 0; y < r.synth.truth.depth.rows; ++y)
    for (int x = 0; x < r.synth.truth.depth.cols; ++x)
      if (const float z = r.synth.truth.depth.at<float>(y, x); z > 0.0f) inverse.push_back(1.0 / z);
  std::sort(inverse.begin(), inverse.end());
  const auto at = [&inverse](double share) {
    return inverse[static_cast<std::size_t>(share * (inverse.size() - 1))];
  };
  double baseline = 0.0;
  for (const Pose& pose : r.synth.truth.poses)
    baseline = std::max(baseline, pose.Centre().head<2>().norm());
  const double truth = r.synth.truth.camera.f * baseline * (at(0.98) - at(0.02));
  ASSERT_GT(truth, 1.0);  // a burst that shows depth
  EXPECT_NEAR(pinned->parallax_range_px / truth, 1.0, 0.1);
}

// No truth at the tracks (a depth sensor that saw nothing): no answer.
TEST(PinnedDepth, NoAnswerWithoutTruthAtTheTracks) {
  const Reconstructed r = Reconstruct();
  const cv::Mat none(r.synth.truth.depth.size(), CV_32FC1, cv::Scalar(0.0f));
  EXPECT_FALSE(
      PinDepthToTruth(r.burst, none, cv::Mat(), r.sparse, r.options.sparse, r.options.dense));
}

TEST(PinnedDepth, OptionsOutOfRangeAreNamed) {
  PinnedDepthOptions options;
  options.Check();
  options.flat_radius = -1;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = {};
  options.flat_tolerance = 0.0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = {};
  options.min_tracks = 0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
