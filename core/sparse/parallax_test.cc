#include "core/sparse/parallax.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

// Noise-free tracks of a lens without distortion, and the state they were
// made from.
struct Scene {
  TrackSimulation sim;
  SparseState state;
};

Scene MakeScene(double baseline, double rotation_deg) {
  TrackSimulatorOptions options;
  options.k1 = options.k2 = 0.0;
  options.baseline = baseline;
  options.rotation_deg = rotation_deg;
  Scene scene;
  scene.sim = SimulateTracks(options);
  scene.state.camera = scene.sim.camera;
  scene.state.poses = scene.sim.poses;
  scene.state.inverse_depths = scene.sim.inverse_depths;
  return scene;
}

Parallax Measure(const Scene& scene, double noise_px = 0.05) {
  const std::vector<bool> all(scene.sim.tracks.num_tracks(), true);
  return MeasureParallax(scene.sim.tracks, all, scene.state, noise_px);
}

// Tracks that move by rotation alone show no parallax, however far they move.
TEST(Parallax, RotationAloneShowsNone) {
  const Scene scene = MakeScene(0.0, 2.0);
  EXPECT_GT(scene.sim.tracks.MedianMaxDisplacement(), 40.0);
  const Parallax parallax = Measure(scene);
  EXPECT_LT(parallax.p90_px, 1e-6);
  EXPECT_DOUBLE_EQ(parallax.baseline_over_depth, 0.0);
}

// Without rotation the parallax is the tracks' motion itself.
TEST(Parallax, TranslationAloneIsTheMotion) {
  const Scene scene = MakeScene(0.008, 0.0);
  const Parallax parallax = Measure(scene);
  EXPECT_NEAR(parallax.median_px, scene.sim.tracks.MedianMaxDisplacement(),
              1e-6 * parallax.median_px);
  EXPECT_GE(parallax.p90_px, parallax.median_px);
  EXPECT_NEAR(parallax.relative_depth_sigma, 0.05 / parallax.median_px, 1e-12);
}

// With both, the rotation's share is taken out: the parallax is the
// translation's, far below the tracks' motion, and the baseline over the
// median depth is the path's extent over it.
TEST(Parallax, TheRotationsShareIsTakenOut) {
  const Scene scene = MakeScene(0.008, 1.0);
  const Parallax parallax = Measure(scene);
  EXPECT_LT(parallax.median_px, 0.5 * scene.sim.tracks.MedianMaxDisplacement());
  EXPECT_GT(parallax.median_px, 1.0);
  std::vector<double> w = scene.sim.inverse_depths;
  std::nth_element(w.begin(), w.begin() + w.size() / 2, w.end());
  double baseline = 0.0;
  for (const Pose& pose : scene.sim.poses) baseline = std::max(baseline, pose.Centre().norm());
  EXPECT_NEAR(parallax.baseline_over_depth, baseline * w[w.size() / 2], 1e-12);
  EXPECT_GT(parallax.baseline_over_depth, 0.001);
}

}  // namespace
}  // namespace dfsm
