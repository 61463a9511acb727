#include "core/sparse/rolling_shutter_rectification.h"

#include <gtest/gtest.h>

#include "core/sparse/rotation_init.h"
#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

double MeanRotationErrorDeg(const std::vector<Pose>& estimate, const std::vector<Pose>& truth) {
  double sum = 0.0;
  for (size_t i = 1; i < truth.size(); ++i) sum += RotationErrorDeg(estimate[i].R, truth[i].R);
  return sum / (truth.size() - 1);
}

// A phone's readout under 2 degrees of tremor: the global-shutter rank-1
// start is tenths of a degree off; rectified with the readout (starting from
// that very start's rotations), it is a fraction of that.
TEST(RollingShutterRectification, RankOneOnRectifiedTracksRecoversTheRotations) {
  for (const uint64_t seed : {1, 2}) {
    TrackSimulatorOptions options;
    options.rotation_deg = 2.0;
    options.noise_px = 0.02;
    options.readout = 0.6;
    options.seed = seed;
    const TrackSimulation sim = SimulateTracks(options);
    const RankOneResult global =
        RankOneInit(sim.tracks, sim.camera, EstimateRotations(sim.tracks, sim.camera));
    ASSERT_TRUE(global.ok);
    const RankOneResult rectified =
        RectifiedRankOneInit(sim.tracks, sim.camera, global.poses, 0.6, 3);
    ASSERT_TRUE(rectified.ok);
    const double before = MeanRotationErrorDeg(global.poses, sim.poses);
    const double after = MeanRotationErrorDeg(rectified.poses, sim.poses);
    EXPECT_LT(after, before / 3.0)
        << "seed " << seed << ": " << before << " -> " << after << " deg";
    EXPECT_LT(rectified.rms_residual_px, global.rms_residual_px) << "seed " << seed;
  }
}

TEST(RollingShutterRectification, AGlobalShutterLeavesTheTracksAlone) {
  TrackSimulatorOptions options;
  options.tracks = 50;
  const TrackSimulation sim = SimulateTracks(options);
  const FeatureTracks same = RectifyRollingShutter(sim.tracks, sim.camera, sim.poses, 0.0);
  for (int i = 0; i < sim.tracks.num_frames(); ++i)
    EXPECT_LT((same.pixels[i] - sim.tracks.pixels[i]).cwiseAbs().maxCoeff(), 1e-9);
  // A row moves by its time from the middle row: the rows near the middle
  // barely, the top and bottom most.
  const FeatureTracks rectified = RectifyRollingShutter(sim.tracks, sim.camera, sim.poses, 0.6);
  double near = 0.0, far = 0.0;
  int near_count = 0, far_count = 0;
  for (int i = 0; i < sim.tracks.num_frames(); ++i)
    for (int j = 0; j < sim.tracks.num_tracks(); ++j) {
      const double offset = std::abs(sim.tracks.pixels[i](1, j) / sim.camera.height - 0.5);
      const double moved = (rectified.pixels[i].col(j) - sim.tracks.pixels[i].col(j)).norm();
      if (offset < 0.125) near += moved, ++near_count;
      if (offset > 0.375) far += moved, ++far_count;
    }
  ASSERT_GT(near_count, 0);
  ASSERT_GT(far_count, 0);
  EXPECT_GT(far / far_count, 3.0 * near / near_count);
}

}  // namespace
}  // namespace dfsm
