// Dense-stage (plane sweep) benchmarks on bursts from the ground-truth
// generator, with the true camera and poses. Operating point: 1920x1080, 10
// frames, 128 planes; target on the 2-core CI machine: the whole dense stage
// <= 1.2 s wall, peak RSS <= 600 MB. The scaling runs vary one of resolution,
// frames and planes. Counters carry the sub-stage timings (ms) of the last
// iteration and the share of pixels with a depth.
// Run: build/bench/dense_bench --benchmark_format=json
#include <benchmark/benchmark.h>

#include "bench/rendered_burst.h"
#include "core/dense/dense_depth.h"

namespace dfsm {
namespace {

// The first `frames` frames of `scene` (reference 0 included), with the
// truth standing in for the sparse stage's inverse depths.
void RunDense(benchmark::State& state, const RenderedBurst& scene, int frames, int planes,
              bool regularize = DenseOptions().regularize) {
  Burst burst = scene.burst;
  const std::vector<double> sparse_inverse_depths = SparseInverseDepthsFromTruth(scene.truth);
  burst.gray.resize(frames);
  burst.manifest.frames.resize(frames);
  const std::vector<Pose> poses(scene.truth.poses.begin(), scene.truth.poses.begin() + frames);
  DenseOptions options;
  options.planes = planes;
  options.regularize = regularize;
  DenseDepth dense;
  for (auto _ : state)
    dense = ComputeDenseDepth(burst, scene.truth.camera, poses, sparse_inverse_depths, options);
  for (const auto& [stage, ms] : dense.timings_ms) state.counters[stage + "_ms"] = ms;
  state.counters["valid_fraction"] = dense.valid_fraction;
  state.counters["pixels"] = static_cast<double>(burst.width()) * burst.height();
}

// The operating point.
void BM_Dense1080p(benchmark::State& state) {
  RunDense(state, Rendered(1920, 1080, 15), static_cast<int>(state.range(0)),
           static_cast<int>(state.range(1)));
}
BENCHMARK(BM_Dense1080p)
    ->ArgNames({"frames", "planes"})
    ->Args({10, 128})  // target: <= 1.2 s
    ->Args({5, 128})
    ->Args({15, 128})
    ->Args({10, 64})
    ->Args({10, 256})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

// Resolution scaling at 10 frames, 128 planes.
void BM_DenseResolution(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  RunDense(state, Rendered(width, height, 10), 10, 128);
}
BENCHMARK(BM_DenseResolution)
    ->ArgNames({"width", "height"})
    ->Args({640, 480})
    ->Args({960, 540})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

// The semi-global aggregation of the coarse volume (DenseOptions::regularize)
// against winner-take-all, at 1080p and 640x480 (10 frames, 128 planes): its
// cost is the ratio of the two in one run.
void BM_DenseRegularization(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  RunDense(state, Rendered(width, height, 10), 10, 128, state.range(2) != 0);
}
BENCHMARK(BM_DenseRegularization)
    ->ArgNames({"width", "height", "regularize"})
    ->Args({1920, 1080, 0})
    ->Args({1920, 1080, 1})
    ->Args({640, 480, 0})
    ->Args({640, 480, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

}  // namespace
}  // namespace dfsm

BENCHMARK_MAIN();
