#include "core/sparse/adjustment_starts.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/sparse/sparse_layers.h"
#include "tests/support/rolling_shutter_phone.h"
#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

// A wide phone camera: a rolling shutter whose readout the adjustment
// estimates (so the readout restarts run) and two focal starts.
TrackSimulatorOptions PhoneCamera() { return RollingShutterPhone(420.0, 5); }

TrackSimulation PhoneTracks() { return SimulateTracks(PhoneCamera()); }

// The phone camera's scene through a wide lens (f 0.5 x 640 px) with a
// global shutter.
TrackSimulation WideLensTracks() {
  TrackSimulatorOptions camera = PhoneCamera();
  camera.f = 0.5 * 640;
  camera.readout = 0.0;
  return SimulateTracks(camera);
}

struct Adjusted {
  AdjustmentAttempt attempt;
  std::vector<std::pair<std::string, double>> laps;
};

Adjusted AdjustOn(int threads, const TrackSimulation& sim, const SparseOptions& options) {
  const int before = cv::getNumThreads();
  cv::setNumThreads(threads);
  BundleAdjustmentOptions adjust = options.bundle_adjustment;
  adjust.estimate_readout = true;
  Adjusted adjusted;
  StageTimer timer(&adjusted.laps);
  adjusted.attempt =
      AdjustFromStarts(sim.tracks, CameraModel::Initial(640, 480), options, adjust, &timer);
  cv::setNumThreads(before);
  return adjusted;
}

// The starts and the readout restarts run side by side, but each adjustment
// is single-threaded and the winner is picked in order: one core and two
// give the same bits.
TEST(AdjustFromStarts, GivesTheSameResultOnOneCoreAsOnTwo) {
  const TrackSimulation sim = PhoneTracks();
  const SparseOptions options = EstimatingTheReadout();
  const AdjustmentAttempt one = AdjustOn(1, sim, options).attempt;
  const AdjustmentAttempt two = AdjustOn(2, sim, options).attempt;
  // The first adjustment measured a readout, so the readout restarts ran
  // side by side (kReadoutStarts: two at least beside the measured one).
  ASSERT_GE(one.runs.size(), 3u);
  EXPECT_GT(one.state.readout, 0.3);
  EXPECT_EQ(one.state.camera.f, two.state.camera.f);
  EXPECT_EQ(one.state.camera.k1, two.state.camera.k1);
  EXPECT_EQ(one.state.camera.k2, two.state.camera.k2);
  EXPECT_EQ(one.state.readout, two.state.readout);
  EXPECT_EQ(one.state.inverse_depths, two.state.inverse_depths);
  ASSERT_EQ(one.state.poses.size(), two.state.poses.size());
  for (size_t i = 0; i < one.state.poses.size(); ++i) {
    EXPECT_EQ(one.state.poses[i].R, two.state.poses[i].R) << "frame " << i;
    EXPECT_EQ(one.state.poses[i].T, two.state.poses[i].T) << "frame " << i;
  }
  EXPECT_EQ(one.use, two.use);
  EXPECT_EQ(one.start_f, two.start_f);
  ASSERT_EQ(one.runs.size(), two.runs.size());
  for (size_t r = 0; r < one.runs.size(); ++r) {
    EXPECT_EQ(one.runs[r].iterations, two.runs[r].iterations) << "run " << r;
    EXPECT_EQ(one.runs[r].tracks, two.runs[r].tracks) << "run " << r;
    EXPECT_EQ(one.runs[r].converged, two.runs[r].converged) << "run " << r;
    EXPECT_EQ(one.runs[r].final_cost, two.runs[r].final_cost) << "run " << r;
  }
  EXPECT_EQ(one.summary.initial_cost, two.summary.initial_cost);
  EXPECT_EQ(one.summary.final_cost, two.summary.final_cost);
  EXPECT_EQ(one.summary.rms_reprojection_px, two.summary.rms_reprojection_px);
  EXPECT_EQ(one.rank_one.inverse_depths, two.rank_one.inverse_depths);
  EXPECT_EQ(one.rank_one.iterations, two.rank_one.iterations);
  EXPECT_NEAR(one.state.camera.f, sim.camera.f, 0.05 * sim.camera.f);
}

// Every start has a record, in the order they were decided: the two focal
// starts and the naive probe, one of them chosen, then the chosen one's
// readout restarts, one of which is chosen where it beat the solution it
// restarted from. Without the layers that make them (sparse_layers.h), only
// the first start is left.
TEST(AdjustFromStarts, RecordsEveryStartAndWhatBecameOfIt) {
  const TrackSimulation sim = PhoneTracks();
  const SparseOptions options = EstimatingTheReadout();
  const AdjustmentAttempt solved = AdjustOn(2, sim, options).attempt;
  ASSERT_GE(solved.starts.size(), 5u);  // 2 focal, 1 naive, >= 2 readout
  EXPECT_EQ(solved.starts[0].kind, StartKind::kFocal);
  EXPECT_EQ(solved.starts[1].kind, StartKind::kFocal);
  EXPECT_EQ(solved.starts[2].kind, StartKind::kNaive);
  EXPECT_DOUBLE_EQ(solved.starts[0].start_f, options.focal_starts[0] * 640);
  EXPECT_DOUBLE_EQ(solved.starts[1].start_f, options.focal_starts[1] * 640);
  int chosen = 0;
  for (size_t n = 0; n < 3; ++n) {
    chosen += solved.starts[n].outcome == StartOutcome::kChosen;
    EXPECT_TRUE(std::isfinite(solved.starts[n].cost)) << n;
    EXPECT_GT(solved.starts[n].iterations, 0) << n;
    EXPECT_GE(solved.starts[n].tracks, options.min_tracks) << n;
  }
  EXPECT_EQ(chosen, 1);
  int readout_chosen = 0;
  for (size_t n = 3; n < solved.starts.size(); ++n) {
    EXPECT_EQ(solved.starts[n].kind, StartKind::kReadout) << n;
    readout_chosen += solved.starts[n].outcome == StartOutcome::kChosen;
  }
  EXPECT_LE(readout_chosen, 1);

  SparseOptions bare = options;
  for (const SparseLayer layer :
       {SparseLayer::kFocalStarts, SparseLayer::kNaiveProbe, SparseLayer::kReadoutRestarts})
    bare = WithoutLayer(bare, layer);
  const AdjustmentAttempt alone = AdjustOn(2, sim, bare).attempt;
  ASSERT_EQ(alone.starts.size(), 1u);
  EXPECT_EQ(alone.starts[0].kind, StartKind::kFocal);
  EXPECT_EQ(alone.starts[0].outcome, StartOutcome::kChosen);
  EXPECT_NEAR(alone.state.camera.f, sim.camera.f, 0.05 * sim.camera.f);
}

// The laps are the first start's stages, then what the later starts added,
// whichever start ran where.
TEST(AdjustFromStarts, LapsTheFirstStartThenTheOthers) {
  const TrackSimulation sim = PhoneTracks();
  for (const int threads : {1, 2}) {
    const Adjusted adjusted = AdjustOn(threads, sim, EstimatingTheReadout());
    std::vector<std::string> stages;
    for (const auto& [stage, ms] : adjusted.laps) stages.push_back(stage);
    EXPECT_EQ(stages, (std::vector<std::string>{"rotation", "rank1", "bundle_adjustment",
                                                "later_starts", "reweight"}))
        << threads << " threads";
  }
}

// The caller's pieces (SharedWork) fill the core the first start leaves
// while the probe runs: on two threads the start done first takes them up,
// the result is the same bits as without them, and the time they keep the
// region open is a lap of its own. On one thread the starts run one after
// the other and leave no core idle: nothing is taken.
TEST(AdjustFromStarts, TakesUpTheCallersPiecesAndChangesNothing) {
  const TrackSimulation sim = PhoneTracks();
  const SparseOptions options = EstimatingTheReadout();
  BundleAdjustmentOptions adjust = options.bundle_adjustment;
  adjust.estimate_readout = true;
  const AdjustmentAttempt alone = AdjustOn(2, sim, options).attempt;
  for (const int threads : {1, 2}) {
    const int before = cv::getNumThreads();
    cv::setNumThreads(threads);
    std::vector<std::atomic<int>> runs(12);
    std::vector<std::function<void()>> pieces;
    for (size_t i = 0; i < runs.size(); ++i) pieces.push_back([&runs, i] { ++runs[i]; });
    SharedWork beside(std::move(pieces));
    std::vector<std::pair<std::string, double>> laps;
    StageTimer timer(&laps);
    const AdjustmentAttempt attempt = AdjustFromStarts(sim.tracks, CameraModel::Initial(640, 480),
                                                       options, adjust, &timer, &beside);
    const int taken = beside.taken();
    beside.Finish();
    cv::setNumThreads(before);
    for (size_t i = 0; i < runs.size(); ++i) EXPECT_EQ(runs[i].load(), 1) << "piece " << i;
    std::vector<std::string> stages;
    for (const auto& [stage, ms] : laps) stages.push_back(stage);
    if (threads == 1) {
      EXPECT_EQ(taken, 0);
      EXPECT_EQ(stages, (std::vector<std::string>{"rotation", "rank1", "bundle_adjustment",
                                                  "later_starts", "reweight"}));
    } else {
      // The start done first took them (the other ran hundreds of ms longer).
      EXPECT_GT(taken, 0);
      EXPECT_EQ(stages, (std::vector<std::string>{"rotation", "rank1", "bundle_adjustment",
                                                  "beside_starts", "later_starts", "reweight"}));
    }
    EXPECT_EQ(attempt.state.camera.f, alone.state.camera.f) << threads << " threads";
    EXPECT_EQ(attempt.state.readout, alone.state.readout);
    EXPECT_EQ(attempt.state.inverse_depths, alone.state.inverse_depths);
    EXPECT_EQ(attempt.use, alone.use);
  }
}

// A known camera is where every start starts: the rank-1 start and the
// naive probe beside it, both held at the known f. Without the probe it
// starts once, and one start leaves no core idle: the caller's pieces are
// left to it.
TEST(AdjustFromStarts, AKnownCameraStartsFromItself) {
  const TrackSimulation sim = PhoneTracks();
  SparseOptions options = EstimatingTheReadout();
  KnownCalibration known;
  known.camera = sim.camera;
  known.mode = KnownCalibrationMode::kFixed;
  options.known = known;
  BundleAdjustmentOptions adjust = options.bundle_adjustment;
  adjust.fix_intrinsics = true;
  adjust.estimate_readout = true;
  for (const bool probe : {true, false}) {
    options.naive_probe = probe;
    std::vector<std::pair<std::string, double>> laps;
    StageTimer timer(&laps);
    const AdjustmentAttempt attempt =
        AdjustFromStarts(sim.tracks, sim.camera, options, adjust, &timer);
    EXPECT_EQ(attempt.start_f, sim.camera.f) << "probe " << probe;
    EXPECT_EQ(attempt.state.camera.f, sim.camera.f) << "probe " << probe;
    std::vector<std::string> stages;
    for (const auto& [stage, ms] : laps) stages.push_back(stage);
    const std::vector<std::string> expected =
        probe ? std::vector<std::string>{"rotation", "rank1", "bundle_adjustment", "later_starts",
                                         "reweight"}
              : std::vector<std::string>{"rotation", "rank1", "bundle_adjustment", "reweight"};
    EXPECT_EQ(stages, expected);
  }
  options.naive_probe = false;
  SharedWork beside({[] {}});
  AdjustFromStarts(sim.tracks, sim.camera, options, adjust, nullptr, &beside);
  EXPECT_EQ(beside.taken(), 0);
}

// Where both starts reach the same minimum, the rank-1 start, tried first,
// stands and the probe changes nothing: the result is the one without it,
// bit for bit. (Where the rank-1 start settles in a worse minimum the probe
// wins: TUM fr1/xyz window 18-27, tests/tum_pipeline_test.cc.)
TEST(AdjustFromStarts, TheNaiveProbeLeavesASolutionBothStartsReachAsItWas) {
  for (const uint64_t seed : {5u, 6u}) {
    TrackSimulatorOptions camera = PhoneCamera();
    camera.seed = seed;
    const TrackSimulation sim = SimulateTracks(camera);
    SparseOptions options = EstimatingTheReadout();
    const AdjustmentAttempt probed = AdjustOn(2, sim, options).attempt;
    options.naive_probe = false;
    const AdjustmentAttempt alone = AdjustOn(2, sim, options).attempt;
    EXPECT_EQ(probed.init, InitMode::kRankOne) << "seed " << seed;
    EXPECT_EQ(alone.init, InitMode::kRankOne) << "seed " << seed;
    EXPECT_EQ(probed.state.camera.f, alone.state.camera.f) << "seed " << seed;
    EXPECT_EQ(probed.state.readout, alone.state.readout) << "seed " << seed;
    EXPECT_EQ(probed.state.inverse_depths, alone.state.inverse_depths) << "seed " << seed;
    EXPECT_EQ(probed.use, alone.use) << "seed " << seed;
    EXPECT_NEAR(probed.state.camera.f, sim.camera.f, 0.05 * sim.camera.f) << "seed " << seed;
  }
}

// A probe adjusts a share of its tracks (160, evenly spaced); one that
// wins takes in the tracks its geometry explains before it goes on: a second
// focal start at a wide lens's f where the first is 4 times too long, 300
// tracks.
TEST(AdjustFromStarts, AProbeThatWinsAdjustsEveryTrack) {
  const TrackSimulation sim = WideLensTracks();
  SparseOptions options;
  options.focal_starts = {2.0, 0.5};
  options.naive_probe = false;
  const AdjustmentAttempt attempt = AdjustOn(2, sim, options).attempt;
  ASSERT_DOUBLE_EQ(attempt.start_f, 320.0) << "f " << attempt.state.camera.f;
  EXPECT_TRUE(attempt.thinned_from.empty());
  ASSERT_GE(attempt.runs.size(), 2u);
  // The probe's own adjustment ran on its share of the tracks, the next on
  // the tracks it took in beside them, and the solution keeps nearly all.
  EXPECT_EQ(attempt.runs[0].tracks, 160);
  EXPECT_GT(attempt.runs[1].tracks, sim.tracks.num_tracks() * 9 / 10);
  const int used = static_cast<int>(std::count(attempt.use.begin(), attempt.use.end(), true));
  EXPECT_GT(used, sim.tracks.num_tracks() * 9 / 10);
  // The same on one core (the probe then runs after the first start).
  const AdjustmentAttempt alone = AdjustOn(1, sim, options).attempt;
  EXPECT_EQ(alone.start_f, attempt.start_f);
  EXPECT_EQ(alone.state.camera.f, attempt.state.camera.f);
  EXPECT_EQ(alone.state.inverse_depths, attempt.state.inverse_depths);
  EXPECT_EQ(alone.use, attempt.use);
  EXPECT_NEAR(attempt.state.camera.f, sim.camera.f, 0.06 * sim.camera.f);  // measured 3.6 %
}

// A given start (ReconstructSparse gives the burst's own solution under a
// known camera) is probed beside the others and judged as they are: from
// the true scene where the only focal start is 4 times too long, it wins,
// keeps nearly every track and finds the camera; given the solution the
// starts reach anyway, it is not clearly better and changes nothing.
TEST(AdjustFromStarts, AGivenStartIsProbedAndJudgedAsTheOthers) {
  const TrackSimulation sim = WideLensTracks();
  SparseOptions options;
  options.focal_starts = {2.0};
  options.naive_probe = false;
  GivenStart truth;
  truth.state.camera = sim.camera;
  truth.state.poses = sim.poses;
  truth.state.inverse_depths = sim.inverse_depths;
  truth.use.assign(sim.tracks.num_tracks(), true);
  const BundleAdjustmentOptions adjust = options.bundle_adjustment;
  const AdjustmentAttempt alone =
      AdjustFromStarts(sim.tracks, CameraModel::Initial(640, 480), options, adjust, nullptr);
  EXPECT_FALSE(alone.given);
  EXPECT_GT(std::abs(alone.state.camera.f - sim.camera.f), 0.1 * sim.camera.f)
      << "f " << alone.state.camera.f << ": the focal start alone found the camera";
  const AdjustmentAttempt given = AdjustFromStarts(sim.tracks, CameraModel::Initial(640, 480),
                                                   options, adjust, nullptr, nullptr, &truth);
  EXPECT_TRUE(given.given);
  EXPECT_NEAR(given.state.camera.f, sim.camera.f, 0.03 * sim.camera.f);
  const int used = static_cast<int>(std::count(given.use.begin(), given.use.end(), true));
  EXPECT_GT(used, sim.tracks.num_tracks() * 9 / 10);

  // The true camera known: the starts made under it reach the minimum the
  // given start (their own solution) stands at, and the first stands.
  options.focal_starts = {1.0};
  options.naive_probe = true;
  KnownCalibration known;
  known.camera = sim.camera;
  known.mode = KnownCalibrationMode::kFixed;
  options.known = known;
  BundleAdjustmentOptions fixed = adjust;
  fixed.fix_intrinsics = true;
  const AdjustmentAttempt made = AdjustFromStarts(sim.tracks, sim.camera, options, fixed, nullptr);
  GivenStart own{made.state, made.use, made.init};
  const AdjustmentAttempt again =
      AdjustFromStarts(sim.tracks, sim.camera, options, fixed, nullptr, nullptr, &own);
  EXPECT_FALSE(again.given);
  EXPECT_EQ(again.state.inverse_depths, made.state.inverse_depths);
  EXPECT_EQ(again.use, made.use);
}

// Tracks that are noisier than the rest (a corner in weak texture, blur)
// weigh less in the reweighting rounds; the median track and the ones below
// it keep weight 1, and no weight falls under min_track_weight. The camera
// (f, k1, k2, the readout) is held at the equal-weight solution's.
TEST(AdjustFromStarts, NoisierTracksWeighLessAndTheCameraIsHeld) {
  // The phone camera's scene with a global shutter.
  TrackSimulatorOptions simulated = PhoneCamera();
  simulated.noise_px = 0.04;
  simulated.readout = 0.0;
  SparseOptions weighted;
  SparseOptions equal;
  equal.reweight_rounds = 0;
  for (const uint64_t draw : {11, 12, 13, 14}) {
    simulated.noise_seed = draw;
    TrackSimulation sim = SimulateTracks(simulated);
    // Every fourth track tracks four times worse.
    cv::RNG rng(static_cast<uint64_t>(draw));
    std::vector<bool> noisy(sim.tracks.num_tracks(), false);
    for (int j = 0; j < sim.tracks.num_tracks(); j += 4) {
      noisy[j] = true;
      for (int i = 0; i < sim.tracks.num_frames(); ++i)
        if (i != sim.tracks.reference)
          sim.tracks.pixels[i].col(j) += Eigen::Vector2d(rng.gaussian(0.12), rng.gaussian(0.12));
    }
    const AdjustmentAttempt a = AdjustOn(2, sim, weighted).attempt;
    const AdjustmentAttempt b = AdjustOn(2, sim, equal).attempt;
    EXPECT_TRUE(b.weights.empty());
    ASSERT_EQ(a.weights.size(), static_cast<size_t>(sim.tracks.num_tracks()));
    EXPECT_EQ(a.state.camera.f, b.state.camera.f) << "draw " << draw;
    EXPECT_EQ(a.state.camera.k1, b.state.camera.k1) << "draw " << draw;
    EXPECT_EQ(a.state.readout, b.state.readout) << "draw " << draw;
    double noisy_sum = 0.0;
    int noisy_used = 0, quiet_used = 0, quiet_whole = 0;
    for (size_t j = 0; j < a.weights.size(); ++j) {
      EXPECT_GE(a.weights[j], weighted.min_track_weight);
      EXPECT_LE(a.weights[j], 1.0);
      if (!a.use[j]) continue;
      if (noisy[j]) {
        noisy_sum += a.weights[j], ++noisy_used;
      } else {
        ++quiet_used;
        quiet_whole += a.weights[j] == 1.0;
      }
    }
    ASSERT_GT(noisy_used, 10) << "draw " << draw;
    EXPECT_LT(noisy_sum / noisy_used, 0.4) << "draw " << draw;
    EXPECT_GT(quiet_whole, quiet_used / 2) << "draw " << draw;
    // The rounds refined the poses (the sweeps in
    // docs/experiments/125-track-weights.md measure what that does to the depth).
    EXPECT_NE(a.state.inverse_depths, b.state.inverse_depths) << "draw " << draw;
  }
}

}  // namespace
}  // namespace dfsm
