// The whole method on one burst, warm, as the daemon runs it: sparse
// reconstruction (features + KLT, rotations, rank-1, bundle adjustment) and
// dense depth, from frames in memory to the depth map (no file I/O).
// Operating point: 1920x1080, 10 frames, 128 planes; target on the 2-core CI
// machine: <= 1.5 s wall, <= 600 MB peak RSS.
//
// Counters: the stage timings (ms) of the last iteration, the dense
// sub-stages, and peak_rss_mb, the process's peak resident set while the
// pipeline ran (the peak is reset after the burst is rendered, so the
// renderer's own memory is not counted).
//
// BM_PipelinePhone1080pKnown: the phone burst with its true camera held, the
// frames' angular velocities estimated or not (velocity 1 / 0), side by side.
//
// BM_ProcessCommand: what a user of the command line waits for, the whole
// `dfsm process` (start-up, reading and decoding the burst, the pipeline,
// writing every file) on a 1080p x 10 burst written to disk, against the
// pipeline's own time in result.json. Target: wall <= 1.25 x pipeline.
// DFSM_BENCH_BINARY=/path/to/dfsm times another build under the same client.
// Run: build/bench/pipeline_bench --benchmark_format=json
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <string>

#include "bench/rendered_burst.h"
#include "core/pipeline/pipeline.h"

namespace dfsm {
namespace {

// VmHWM of this process in MB; -1 where /proc cannot tell.
double PeakRssMb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return -1.0;
}

// Writing 5 to clear_refs resets VmHWM to the current RSS (Linux >= 4.0).
void ResetPeakRss() { std::ofstream("/proc/self/clear_refs") << "5"; }

// How the sparse stage takes the camera: the burst's true camera held
// (KnownCalibrationMode::kFixed) or calibrated by the burst; each frame's
// angular velocity where the camera is pinned (angular_velocity) or the line
// between frames throughout.
struct CameraUse {
  bool held = false;
  bool angular_velocity = true;
};

void RunWholePipeline(benchmark::State& state, int width, int height,
                      const std::string& camera = "ideal", double rotation_deg = 0.0,
                      CameraUse use = {}) {
  const RenderedBurst& rendered =
      Rendered(width, height, static_cast<int>(state.range(0)), camera, rotation_deg);
  const Burst& burst = rendered.burst;
  PipelineOptions options;
  options.dense.planes = static_cast<int>(state.range(1));
  if (use.held) {
    KnownCalibration fixed;
    fixed.camera = rendered.truth.camera;
    fixed.mode = KnownCalibrationMode::kFixed;
    options.sparse.known = fixed;
  }
  if (!use.angular_velocity) options.sparse.angular_velocity_sigma_px = 0.0;
  ResetPeakRss();
  const double rss_before = PeakRssMb();
  PipelineOutput output;
  for (auto _ : state) {
    output = RunPipeline(burst, options);
    if (!output.result.ok) {
      state.SkipWithError(("pipeline failed: " + output.result.error).c_str());
      return;
    }
  }
  for (const auto& [stage, ms] : output.sparse->timings_ms) state.counters[stage + "_ms"] = ms;
  double dense_ms = 0.0;
  for (const auto& [stage, ms] : output.dense->timings_ms) {
    state.counters["dense_" + stage + "_ms"] = ms;
    dense_ms += ms;
  }
  state.counters["dense_ms"] = dense_ms;
  state.counters["tracks"] = output.sparse->tracks.num_tracks();
  state.counters["valid_fraction"] = output.dense->valid_fraction;
  state.counters["rss_before_mb"] = rss_before;
  state.counters["peak_rss_mb"] = PeakRssMb();
}

// The operating point (target <= 1.5 s wall, <= 600 MB), then frames and planes.
void BM_Pipeline1080p(benchmark::State& state) { RunWholePipeline(state, 1920, 1080); }
BENCHMARK(BM_Pipeline1080p)
    ->ArgNames({"frames", "planes"})
    ->Args({10, 128})
    ->Args({15, 128})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(3.0);

// A phone's burst (the generator's phone preset: rolling shutter, exposure
// drift, blur, JPEG 90; 1 deg of tremor): what a phone user waits for.
// Beside BM_Pipeline1080p's ideal burst the bundle adjustment is the stage
// that grows (docs/experiments/116-readout-measuring-adjustment.md). Its
// calibration is observed, so the solution is refined with each frame's
// angular velocity (velocity 1) or stays on the line (0).
void BM_PipelinePhone1080p(benchmark::State& state) {
  RunWholePipeline(state, 1920, 1080, "phone", 1.0, CameraUse{false, state.range(2) != 0});
}
BENCHMARK(BM_PipelinePhone1080p)
    ->ArgNames({"frames", "planes", "velocity"})
    ->Args({10, 128, 1})
    ->Args({10, 128, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(3.0);

// The same phone burst with its true camera held, each frame's angular
// velocity estimated (velocity 1) or the line between frames (0): what the
// velocities cost a user who gives the camera's calibration.
void BM_PipelinePhone1080pKnown(benchmark::State& state) {
  RunWholePipeline(state, 1920, 1080, "phone", 1.0, CameraUse{true, state.range(2) != 0});
}
BENCHMARK(BM_PipelinePhone1080pKnown)
    ->ArgNames({"frames", "planes", "velocity"})
    ->Args({10, 128, 0})
    ->Args({10, 128, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(3.0);

void BM_PipelineVga(benchmark::State& state) { RunWholePipeline(state, 640, 480); }
BENCHMARK(BM_PipelineVga)
    ->ArgNames({"frames", "planes"})
    ->Args({10, 128})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

// What the user waits for after the pipeline: WritePipelineOutputs on one
// 1080p result (every file encoded, written and flushed, result.json last).
// Counter: the serial encode time (one thread), to compare with the wall time
// of the parallel writers in the same run.
void BM_WritePipelineOutputs(benchmark::State& state) {
  const Burst& burst = Rendered(1920, 1080, 10).burst;
  PipelineOptions options;
  options.dense.planes = 64;
  const PipelineOutput computed = RunPipeline(burst, options);
  if (!computed.result.ok) {
    state.SkipWithError(("pipeline failed: " + computed.result.error).c_str());
    return;
  }
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dfsm-write-bench-" + std::to_string(::getpid()));
  const int threads = static_cast<int>(state.range(0));
  const int before = cv::getNumThreads();
  if (threads > 0) cv::setNumThreads(threads);
  for (auto _ : state) {
    std::filesystem::remove_all(dir);
    PipelineOutput output = computed;
    WritePipelineOutputs(dir, burst, &output);
    state.counters["write_ms"] = output.result.extra.value("write_ms", 0.0);
  }
  cv::setNumThreads(before);
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_WritePipelineOutputs)
    ->ArgNames({"threads"})
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

// Runs `argv` with stdout and stderr on /dev/null; its exit status, -1 when it
// did not run.
int Run(const std::vector<std::string>& argv) {
  const pid_t pid = ::fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    std::vector<char*> args;
    for (const std::string& arg : argv) args.push_back(const_cast<char*>(arg.c_str()));
    args.push_back(nullptr);
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::dup2(null, 2);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

void BM_ProcessCommand(benchmark::State& state) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dfsm-process-bench-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  SynthOptions synth;
  synth.width = 1920;
  synth.height = 1080;
  synth.frames = 10;
  WriteSynthBurst(dir / "burst", SynthesizeBurst(synth));
  // DFSM_BENCH_BINARY: another dfsm to compare (an installed package, an
  // older build) in the same run.
  const char* other = std::getenv("DFSM_BENCH_BINARY");
  const std::string binary = other && *other ? other : DFSM_BINARY;
  double wall_ms = 0, pipeline_ms = 0;
  for (auto _ : state) {
    std::filesystem::remove_all(dir / "out");
    const auto start = std::chrono::steady_clock::now();
    const int status = Run({binary, "process", (dir / "burst").string(), "--out",
                            (dir / "out").string(), "--planes", "64"});
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    state.SetIterationTime(ms / 1000.0);
    if (status != 0) {
      state.SkipWithError(("dfsm process exited with " + std::to_string(status)).c_str());
      break;
    }
    std::ifstream result(dir / "out" / "result.json");
    wall_ms += ms;
    pipeline_ms += nlohmann::json::parse(result)["timings_ms"]["total"].get<double>();
  }
  std::filesystem::remove_all(dir);
  const double runs = static_cast<double>(state.iterations());
  state.counters["wall_ms"] = wall_ms / runs;
  state.counters["pipeline_ms"] = pipeline_ms / runs;
  state.counters["wall_over_pipeline"] = wall_ms / pipeline_ms;
}
BENCHMARK(BM_ProcessCommand)->UseManualTime()->Iterations(5)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace dfsm

BENCHMARK_MAIN();
