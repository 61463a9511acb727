#include "core/sparse/sparse_reconstruction.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/sparse/sparse_layers.h"
#include "tests/support/rolling_shutter_phone.h"
#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

// A 640x480 camera with a rolling shutter whose readout the adjustment
// estimates, under a degree of tremor and 0.05 px of tracking noise.
TrackSimulatorOptions RollingShutterCamera() { return RollingShutterPhone(520.0, 3); }

// The message of the std::invalid_argument that ReconstructFromTracks throws
// for `options`, or "no error".
std::string Refusal(const TrackSimulation& sim, const SparseOptions& options) {
  try {
    ReconstructFromTracks(sim.tracks, 640, 480, options);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no error";
}

// Every option out of its range is refused before any work, by the option's
// name: the sparse stage's own and those of its parts.
TEST(SparseOptions, AnOptionOutOfItsRangeIsRefusedByName) {
  const TrackSimulation sim = SimulateTracks(RollingShutterCamera());
  const std::vector<std::pair<std::string, std::function<void(SparseOptions*)>>> cases = {
      {"focal_starts", [](SparseOptions* o) { o->focal_starts = {}; }},
      {"focal_starts",
       [](SparseOptions* o) {
         o->focal_starts = {1.0, 9.0};
       }},
      {"reweight_rounds", [](SparseOptions* o) { o->reweight_rounds = -1; }},
      {"min_track_weight", [](SparseOptions* o) { o->min_track_weight = 0.0; }},
      {"min_track_weight", [](SparseOptions* o) { o->min_track_weight = std::nan(""); }},
      {"min_known_inlier_share", [](SparseOptions* o) { o->min_known_inlier_share = 1.5; }},
      {"max_known_fit_ratio", [](SparseOptions* o) { o->max_known_fit_ratio = 0.5; }},
      {"outlier_rounds", [](SparseOptions* o) { o->outlier_rounds = -2; }},
      {"outlier_px", [](SparseOptions* o) { o->outlier_px = 0.0; }},
      {"min_tracks", [](SparseOptions* o) { o->min_tracks = 2; }},
      {"klt_window", [](SparseOptions* o) { o->features.klt_window = 20; }},
      {"min_quality", [](SparseOptions* o) { o->features.min_quality = 0.0; }},
      {"rank-1 max_iterations", [](SparseOptions* o) { o->rank_one.max_iterations = 0; }},
      {"bootstrap replicas", [](SparseOptions* o) { o->bootstrap.replicas = -1; }},
  };
  for (const auto& [name, spoil] : cases) {
    SparseOptions options = EstimatingTheReadout();
    spoil(&options);
    EXPECT_NE(Refusal(sim, options).find(name), std::string::npos)
        << name << ": " << Refusal(sim, options);
  }
  EXPECT_EQ(Refusal(sim, EstimatingTheReadout()), "no error");
}

// The whole stage on simulated tracks: the camera, the readout and the
// relief come back, the burst's own calibration is the source, every start
// is recorded with one chosen, and the depths are scaled to a median inverse
// depth of 1.
TEST(ReconstructFromTracks, CalibratesARollingShutterCameraFromItsTracks) {
  const TrackSimulation sim = SimulateTracks(RollingShutterCamera());
  const SparseReconstruction sparse =
      ReconstructFromTracks(sim.tracks, 640, 480, EstimatingTheReadout());
  EXPECT_EQ(sparse.calibration_used, CalibrationSource::kSelf);
  EXPECT_NEAR(sparse.state.camera.f, sim.camera.f, 0.03 * sim.camera.f);
  EXPECT_NEAR(sparse.state.readout, 0.6, 0.1);
  EXPECT_GE(std::count(sparse.inliers.begin(), sparse.inliers.end(), true),
            0.9 * sim.tracks.num_tracks());
  std::vector<double> inverse_depths = sparse.InlierInverseDepths();
  std::nth_element(inverse_depths.begin(), inverse_depths.begin() + inverse_depths.size() / 2,
                   inverse_depths.end());
  EXPECT_NEAR(inverse_depths[inverse_depths.size() / 2], 1.0, 1e-9);
  ASSERT_GE(sparse.starts.size(), 3u);
  EXPECT_EQ(std::count_if(sparse.starts.begin(), sparse.starts.begin() + 3,
                          [](const StartRecord& s) { return s.outcome == StartOutcome::kChosen; }),
            1);
  // The relief up to scale: the inverse depths against the truth's.
  double worst = 0.0;
  const double scale = sim.inverse_depths[0] / sparse.state.inverse_depths[0];
  for (int j = 0; j < sim.tracks.num_tracks(); ++j)
    if (sparse.inliers[j])
      worst = std::max(
          worst, std::abs(scale * sparse.state.inverse_depths[j] / sim.inverse_depths[j] - 1.0));
  EXPECT_LT(worst, 0.25);
}

// The mirrored relief of a right solution fits the tracks no better (it
// comes back, or stops in a worse minimum): the solution stays, exactly as
// without the layer, and the ratio is reported.
TEST(ReconstructFromTracks, TheMirroredReliefOfARightSolutionIsNotKept) {
  const TrackSimulation sim = SimulateTracks(RollingShutterCamera());
  const SparseReconstruction sparse =
      ReconstructFromTracks(sim.tracks, 640, 480, EstimatingTheReadout());
  EXPECT_GE(sparse.mirrored_relief_cost_ratio, 0.99);
  EXPECT_FALSE(sparse.mirrored_relief_kept);
  const SparseReconstruction without = ReconstructFromTracks(
      sim.tracks, 640, 480, WithoutLayer(EstimatingTheReadout(), SparseLayer::kMirroredRelief));
  EXPECT_EQ(without.mirrored_relief_cost_ratio, -1.0);
  EXPECT_NEAR(without.state.camera.f, sparse.state.camera.f, 1e-6 * sparse.state.camera.f);
  ASSERT_EQ(without.state.inverse_depths.size(), sparse.state.inverse_depths.size());
  for (size_t j = 0; j < sparse.state.inverse_depths.size(); ++j)
    EXPECT_NEAR(without.state.inverse_depths[j], sparse.state.inverse_depths[j], 1e-6) << j;
}

// The parallax the stage hands on (result.json's, the depth check's) is that
// of its final solution, its noise the solution's RMS error.
TEST(ReconstructFromTracks, TheParallaxIsTheSolutions) {
  const TrackSimulation sim = SimulateTracks(RollingShutterCamera());
  const SparseReconstruction sparse =
      ReconstructFromTracks(sim.tracks, 640, 480, EstimatingTheReadout());
  const Parallax parallax = MeasureParallax(sparse.tracks, sparse.inliers, sparse.state,
                                            sparse.bundle_adjustment.rms_reprojection_px);
  EXPECT_GT(sparse.parallax.median_px, 0.5);
  EXPECT_EQ(sparse.parallax.median_px, parallax.median_px);
  EXPECT_EQ(sparse.parallax.p90_px, parallax.p90_px);
  EXPECT_EQ(sparse.parallax.relative_depth_sigma, parallax.relative_depth_sigma);
}

// A camera beyond the plausible range (f 12x the image size, a long
// telephoto's) is the user's word where it is given and held: nothing says
// otherwise. The burst's own estimate there, within a prior, is judged
// implausible, which makes its depth unreliable (core/pipeline/depth_check).
TEST(ReconstructFromTracks, OnlyAnEstimatedCameraIsJudgedImplausible) {
  const TrackSimulation sim = SimulateTracks(RollingShutterPhone(12.0 * 640, 3));
  SparseOptions options = EstimatingTheReadout();
  EXPECT_EQ(ImplausibleCamera(sim.camera).size(), 1u);
  options.known.emplace();
  options.known->camera = sim.camera;
  options.known->mode = KnownCalibrationMode::kFixed;
  const SparseReconstruction held = ReconstructFromTracks(sim.tracks, 640, 480, options);
  EXPECT_EQ(held.calibration_used, CalibrationSource::kKnownFixed);
  EXPECT_TRUE(held.implausible_camera.empty()) << held.implausible_camera.front();

  options.known->mode = KnownCalibrationMode::kPrior;
  const SparseReconstruction estimated = ReconstructFromTracks(sim.tracks, 640, 480, options);
  EXPECT_EQ(estimated.calibration_used, CalibrationSource::kKnownPrior);
  ASSERT_EQ(estimated.implausible_camera.size(), 1u);
  EXPECT_EQ(estimated.implausible_camera[0].rfind("implausible focal length", 0), 0u)
      << estimated.implausible_camera[0];
}

// A known camera 15 % off fits the tracks worse than the burst's own: the
// check says so in the verdict and a warning, and never calls it reliable;
// the relief it gives is not the burst's own.
TEST(ReconstructFromTracks, AKnownCameraThatDoesNotFitIsSaidSo) {
  const TrackSimulation sim = SimulateTracks(RollingShutterCamera());
  SparseOptions options = EstimatingTheReadout();
  options.known.emplace();
  options.known->camera = sim.camera;
  options.known->camera.f *= 1.15;
  options.known->mode = KnownCalibrationMode::kFixed;
  const SparseReconstruction sparse = ReconstructFromTracks(sim.tracks, 640, 480, options);
  EXPECT_EQ(sparse.calibration_used, CalibrationSource::kKnownFixed);
  ASSERT_TRUE(sparse.known_fit.has_value());
  EXPECT_FALSE(sparse.known_fit->fits)
      << sparse.known_fit->known_rms_px << " px against " << sparse.known_fit->free_rms_px;
  EXPECT_NE(sparse.verdict.quality, CalibrationQuality::kReliable);
  EXPECT_TRUE(std::any_of(sparse.warnings.begin(), sparse.warnings.end(), [](const std::string& w) {
    return w.find("does not fit") != std::string::npos;
  }));

  options.known->camera = sim.camera;
  const SparseReconstruction right = ReconstructFromTracks(sim.tracks, 640, 480, options);
  ASSERT_TRUE(right.known_fit.has_value());
  EXPECT_TRUE(right.known_fit->fits)
      << right.known_fit->known_rms_px << " px against " << right.known_fit->free_rms_px;
  // The relief moves with the camera: little from the true one to the
  // burst's own, past the depth check's bound from one 15 % off.
  EXPECT_GE(right.camera_relief_disagreement, 0.0);
  EXPECT_LT(right.camera_relief_disagreement, 0.03);
  EXPECT_GT(sparse.camera_relief_disagreement, 0.075);
}

TEST(ReconstructFromTracks, TooFewTracksAreCounted) {
  TrackSimulatorOptions camera = RollingShutterCamera();
  camera.tracks = 12;
  try {
    ReconstructFromTracks(SimulateTracks(camera).tracks, 640, 480, EstimatingTheReadout());
    FAIL() << "12 tracks were adjusted";
  } catch (const ReconstructionError& e) {
    EXPECT_NE(std::string(e.what()).find("too few tracks: 12 (need >= 20)"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dfsm
