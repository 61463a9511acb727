// dfsmd's own costs, measured on the real binary over loopback HTTP with the
// replay source of a generated 320x240 burst:
//  - BM_TriggerToResult: POST /api/v1/captures -> job succeeded (polled every
//    millisecond), minus the pipeline's own time (result.json timings_ms.total).
//    Counters: overhead_ms (client view: waiting for the frames, storing the
//    burst, queue hand-off, writing outputs, polling) and server_overhead_ms
//    (finished_ms - created_ms - total: everything after the burst was stored).
//    accept_ms is the POST alone (frames, burst stored, 202). Target: overhead <= 50 ms. The replay
//    runs at 300 fps and a burst is one whole pass of the 10-frame recording (the pipeline needs
//    the recorded reference view first), so waiting for frames costs at most ~33 ms.
//  - BM_StatusWhileJobRuns: GET /api/v1/jobs/{id} round trips per second on one
//    keep-alive connection per thread while pipeline jobs keep running.
// Run: dfsmd_bench --benchmark_format=json
#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "core/synth/burst_synthesizer.h"
#include "dfsmd/dfsmd_process.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// One daemon for the whole program.
class BenchDaemon {
 public:
  static BenchDaemon& Get() {
    static BenchDaemon daemon;
    return daemon;
  }
  dfsm::test::DfsmdProcess& process() { return *process_; }
  ~BenchDaemon() {
    process_.reset();
    fs::remove_all(dir_);
  }

 private:
  BenchDaemon() {
    dir_ = fs::temp_directory_path() / ("dfsmd-bench-" + std::to_string(::getpid()));
    dfsm::SynthOptions options;
    options.width = 320;
    options.height = 240;
    options.frames = 10;
    options.seed = 3;
    dfsm::WriteSynthBurst(dir_ / "burst", dfsm::SynthesizeBurst(options));
    process_ = std::make_unique<dfsm::test::DfsmdProcess>(
        DFSMD_BINARY,
        std::vector<std::string>{"--capture.source", "replay:" + (dir_ / "burst").string(),
                                 "--jobs.state_dir", (dir_ / "state").string(), "--jobs.queue",
                                 "64", "--capture.fps", "300", "--pipeline.planes", "64",
                                 "--retention.max_jobs", "20"},
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
  httplib::Client client = BenchDaemon::Get().process().Client();
  double overhead_ms = 0, server_overhead_ms = 0, pipeline_ms = 0, accept_ms = 0;
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
    ++jobs;
  }
  state.counters["pipeline_ms"] = pipeline_ms / jobs;
  state.counters["overhead_ms"] = overhead_ms / jobs;
  state.counters["server_overhead_ms"] = server_overhead_ms / jobs;
  state.counters["accept_ms"] = accept_ms / jobs;
}
BENCHMARK(BM_TriggerToResult)->UseManualTime()->Iterations(20)->Unit(benchmark::kMillisecond);

void BM_StatusWhileJobRuns(benchmark::State& state) {
  httplib::Client client = BenchDaemon::Get().process().Client();
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
