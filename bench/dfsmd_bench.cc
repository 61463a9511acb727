// dfsmd's own costs, measured on the real binary over loopback HTTP with the
// replay source of a generated burst:
//  - BM_TriggerToResult/W/H: POST /api/v1/captures -> job succeeded (polled
//    every millisecond), minus the pipeline's own time (result.json
//    timings_ms.total). Counters: accept_ms (the POST alone: frames out of the
//    ring, job recorded, 202; target <= 50 ms at 1080p x 10), overhead_ms
//    (client view: trigger to succeeded minus the pipeline; target <= 150 ms
//    at 1080p x 10) and server_overhead_ms (finished_ms - created_ms - total),
//    of which start_ms (created to started: the queue) and write_ms (the
//    outputs encoded and flushed, result.json's write_ms).
//    The burst is stored beside the pipeline (BurstPersister), so its cost
//    shows as CPU taken from the pipeline where cores are few, not as
//    overhead. The replay stands in for a camera: 30 fps, played back and
//    forth (capture.replay_loop = reverse), so that the ring always holds the
//    last 10 consecutive frames, as it does with a camera. (Until 2026-11-26
//    it ran at 300 fps with a seam after each pass: every POST then waited
//    for a whole pass, and the replay's copying, up to 2.4 GB/s, took ~20 %
//    of the CPU from the pipeline and the writing.)
//  - BM_StatusWhileJobRuns: GET /api/v1/jobs/{id} round trips per second on one
//    keep-alive connection per thread while 320x240 jobs keep running.
// Run: dfsmd_bench --benchmark_format=json
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "core/synth/burst_synthesizer.h"
#include "dfsmd/dfsmd_process.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// One daemon per burst size for the whole program.
class BenchDaemon {
 public:
  static BenchDaemon& Get(int width, int height) {
    static std::map<std::pair<int, int>, std::unique_ptr<BenchDaemon>> daemons;
    auto& daemon = daemons[{width, height}];
    if (!daemon) daemon.reset(new BenchDaemon(width, height));
    return *daemon;
  }
  dfsm::test::DfsmdProcess& process() { return *process_; }
  ~BenchDaemon() {
    process_.reset();
    fs::remove_all(dir_);
  }

 private:
  BenchDaemon(int width, int height) {
    dir_ = fs::temp_directory_path() / ("dfsmd-bench-" + std::to_string(::getpid()) + "-" +
                                        std::to_string(width) + "x" + std::to_string(height));
    dfsm::SynthOptions options;
    options.width = width;
    options.height = height;
    options.frames = 10;
    options.seed = 3;
    dfsm::WriteSynthBurst(dir_ / "burst", dfsm::SynthesizeBurst(options));
    // DFSMD_BENCH_BINARY: another dfsmd to compare (an installed package, an
    // older build) under the same client.
    const char* binary = std::getenv("DFSMD_BENCH_BINARY");
    process_ = std::make_unique<dfsm::test::DfsmdProcess>(
        binary && *binary ? binary : DFSMD_BINARY,
        std::vector<std::string>{"--capture.source", "replay:" + (dir_ / "burst").string(),
                                 "--jobs.state_dir", (dir_ / "state").string(), "--jobs.queue",
                                 "64", "--capture.fps", "30", "--capture.replay_loop", "reverse",
                                 "--pipeline.planes", "64", "--retention.max_jobs", "20"},
        dir_ / "dfsmd.log");
    if (!process_->ok()) {
      std::fprintf(stderr, "dfsmd did not start:\n%s\n", process_->Log().c_str());
      std::exit(1);
    }
  }
  fs::path dir_;
  std::unique_ptr<dfsm::test::DfsmdProcess> process_;
};

std::string Trigger(httplib::Client& client) {
  auto result = client.Post("/api/v1/captures", R"({"frames":10})", "application/json");
  if (!result || result->status != 202) return "";
  return result->get_header_value("Location");
}

void BM_TriggerToResult(benchmark::State& state) {
  BenchDaemon& daemon =
      BenchDaemon::Get(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  httplib::Client client = daemon.process().Client();
  // The first job pays for the ring filling and the pages of a fresh daemon.
  const std::string warm_up = Trigger(client);
  for (json job; !warm_up.empty();) {
    job = json::parse(client.Get(warm_up.c_str())->body);
    if (job["status"] == "succeeded" || job["status"] == "failed") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  double overhead_ms = 0, server_overhead_ms = 0, pipeline_ms = 0, accept_ms = 0, write_ms = 0,
         start_ms = 0;
  int64_t jobs = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const std::string location = Trigger(client);
    if (location.empty()) {
      state.SkipWithError("capture refused");
      return;
    }
    accept_ms +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    json job;
    for (;;) {
      auto result = client.Get(location.c_str());
      job = json::parse(result->body);
      if (job["status"] == "succeeded" || job["status"] == "failed") break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const double wall_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    state.SetIterationTime(wall_ms / 1000.0);
    if (job["status"] != "succeeded") {
      state.SkipWithError(("job failed: " + job.value("error", "")).c_str());
      return;
    }
    const double total = job["timings_ms"]["total"].get<double>();
    pipeline_ms += total;
    overhead_ms += wall_ms - total;
    server_overhead_ms +=
        static_cast<double>(job["finished_ms"].get<int64_t>() - job["created_ms"].get<int64_t>()) -
        total;
    start_ms +=
        static_cast<double>(job["started_ms"].get<int64_t>() - job["created_ms"].get<int64_t>());
    // Outside the timed iteration: where the server's overhead goes.
    if (auto result = client.Get((location + "/result.json").c_str());
        result && result->status == 200)
      write_ms += json::parse(result->body).value("write_ms", 0.0);
    ++jobs;
  }
  state.counters["pipeline_ms"] = pipeline_ms / jobs;
  state.counters["overhead_ms"] = overhead_ms / jobs;
  state.counters["server_overhead_ms"] = server_overhead_ms / jobs;
  state.counters["accept_ms"] = accept_ms / jobs;
  state.counters["start_ms"] = start_ms / jobs;
  state.counters["write_ms"] = write_ms / jobs;
}
BENCHMARK(BM_TriggerToResult)
    ->Args({320, 240})
    ->UseManualTime()
    ->Iterations(20)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TriggerToResult)
    ->Args({1920, 1080})
    ->UseManualTime()
    ->Iterations(6)
    ->Unit(benchmark::kMillisecond);

void BM_StatusWhileJobRuns(benchmark::State& state) {
  httplib::Client client = BenchDaemon::Get(320, 240).process().Client();
  std::string location = Trigger(client);
  int64_t finished_jobs = 0;
  for (auto _ : state) {
    auto result = client.Get(location.c_str());
    if (!result || result->status != 200) {
      state.SkipWithError("status request failed");
      return;
    }
    // Keep a job running: as soon as one has finished, start the next.
    if (result->body.find("\"status\": \"succeeded\"") != std::string::npos ||
        result->body.find("\"status\": \"failed\"") != std::string::npos) {
      ++finished_jobs;
      location = Trigger(client);
    }
  }
  state.counters["requests_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["jobs_finished"] = static_cast<double>(finished_jobs);
}
BENCHMARK(BM_StatusWhileJobRuns)->MinTime(3.0)->Threads(1)->Threads(4)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
