// Sparse-stage benchmarks at the paper's operating point: 1920x1080, 10 frames,
// ~300 grided tracks. Targets (one core of the 2-core CI machine): features+KLT
// <= 150 ms, rotation+rank-1 <= 10 ms, bundle adjustment <= 50 ms.
// Run: build/bench/sparse_bench --benchmark_format=json
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>

#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/grided_features.h"
#include "core/sparse/rank_one_init.h"
#include "core/sparse/rotation_init.h"
#include "core/synth/burst_synthesizer.h"
#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

TrackSimulation Simulation() {
  TrackSimulatorOptions options;
  options.noise_px = 0.03;
  return SimulateTracks(options);
}

void BM_RotationAndRankOne(benchmark::State& state) {
  const TrackSimulation sim = Simulation();
  const CameraModel initial = CameraModel::Initial(sim.camera.width, sim.camera.height);
  for (auto _ : state) {
    const auto rotations = EstimateRotations(sim.tracks, initial);
    benchmark::DoNotOptimize(RankOneInit(sim.tracks, initial, rotations));
  }
  state.counters["tracks"] = sim.tracks.num_tracks();
}
BENCHMARK(BM_RotationAndRankOne)->Unit(benchmark::kMillisecond);

// Argument 1: also the covariance of the intrinsics (what every run of the
// pipeline's adjustment computes); 0: the adjustment alone. Their ratio in one
// run is the uncertainty's cost.
void BM_BundleAdjustment(benchmark::State& state) {
  const bool with_uncertainty = state.range(0) != 0;
  const TrackSimulation sim = Simulation();
  SparseState start;
  start.camera = CameraModel::Initial(sim.camera.width, sim.camera.height);
  const RankOneResult init =
      RankOneInit(sim.tracks, start.camera, EstimateRotations(sim.tracks, start.camera));
  start.poses = init.poses;
  start.inverse_depths = init.inverse_depths;
  BundleAdjustmentSummary summary;
  CalibrationUncertainty uncertainty;
  for (auto _ : state) {
    SparseState adjusted = start;
    summary = RunBundleAdjustment(sim.tracks, init.inliers, &adjusted, {},
                                  with_uncertainty ? &uncertainty : nullptr);
  }
  state.counters["iterations"] = summary.iterations;
  state.counters["converged"] = summary.converged;
}
BENCHMARK(BM_BundleAdjustment)
    ->Arg(0)
    ->Arg(1)
    ->ArgName("uncertainty")
    ->Unit(benchmark::kMillisecond);

void BM_FeaturesAndKlt(benchmark::State& state) {
  SynthOptions options;
  options.width = 1920;
  options.height = 1080;
  options.frames = 10;
  options.supersampling = 2;
  const std::vector<cv::Mat> gray = ToBurst(SynthesizeBurst(options)).gray;
  GridedFeatureOptions features;
  features.gain_bias = state.range(0) != 0;
  GridedFeatureStats stats;
  for (auto _ : state) benchmark::DoNotOptimize(TrackGridedFeatures(gray, 0, features, &stats));
  state.counters["tracks"] = stats.tracks;
}
// gain_bias:0 is KLT alone, to read the realignment's cost as a ratio in one run.
BENCHMARK(BM_FeaturesAndKlt)
    ->Arg(1)
    ->Arg(0)
    ->ArgName("gain_bias")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace dfsm

int main(int argc, char** argv) {
  // The targets are per core: measure on one thread.
  cv::setNumThreads(1);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
