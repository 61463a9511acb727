// Soak (label "soak", runs only with DFSM_TEST_SOAK=1): 1000 capture triggers
// over HTTP against the replay source of a small burst. After a warm-up the
// daemon's peak RSS may grow by less than 5 %, its open descriptors and threads
// must come back to the same count whenever it is idle, and every trigger is
// accounted for: accepted jobs end succeeded or failed (as the client saw them
// and as /metrics counts them), refusals are 503 with Retry-After and retried.
//
//   DFSM_TEST_SOAK=1 ctest --test-dir build -L soak --output-on-failure
//   DFSM_TEST_SOAK=1 DFSM_SOAK_TRIGGERS=200 build/daemon/service/dfsmd_soak_test
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "core/synth/burst_synthesizer.h"
#include "dfsmd/dfsmd_process.h"

namespace dfsm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct ProcessFigures {
  long rss_kb = 0, peak_rss_kb = 0;  // VmRSS, VmHWM
  int threads = 0, fds = 0;
};

int Entries(const fs::path& dir) {
  return static_cast<int>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

// At an idle point: the fewest descriptors and threads seen while sampling
// for up to 3 s (until they are back at `limit`), so that a connection the
// server is still closing on a loaded machine is not counted as a leak.
ProcessFigures MeasureIdle(pid_t pid, const ProcessFigures* limit = nullptr) {
  const fs::path proc = "/proc/" + std::to_string(pid);
  ProcessFigures figures;
  figures.fds = figures.threads = 1 << 20;
  for (int sample = 0; sample < 60; ++sample) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    figures.fds = std::min(figures.fds, Entries(proc / "fd"));
    figures.threads = std::min(figures.threads, Entries(proc / "task"));
    const bool settled =
        limit ? figures.fds <= limit->fds && figures.threads <= limit->threads : sample >= 5;
    if (settled) break;
  }
  std::ifstream status(proc / "status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) == 0) figures.rss_kb = std::stol(line.substr(6));
    if (line.rfind("VmHWM:", 0) == 0) figures.peak_rss_kb = std::stol(line.substr(6));
  }
  return figures;
}

std::string Print(const ProcessFigures& f) {
  return "rss " + std::to_string(f.rss_kb) + " kB, peak rss " + std::to_string(f.peak_rss_kb) +
         " kB, " + std::to_string(f.fds) + " fds, " + std::to_string(f.threads) + " threads";
}

// A counter from /metrics (the line "name value"), -1 when absent.
long Metric(httplib::Client& client, const std::string& name) {
  const std::string text = "\n" + client.Get("/metrics")->body;
  const size_t at = text.find("\n" + name + " ");
  if (at == std::string::npos) return -1;
  return std::stol(text.substr(at + name.size() + 2));
}

int EnvInt(const char* name, int fallback) {
  const char* value = std::getenv(name);
  return value && *value ? std::atoi(value) : fallback;
}

TEST(DfsmdSoak, ThousandTriggersKeepMemoryDescriptorsAndThreadsFlat) {
  if (EnvInt("DFSM_TEST_SOAK", 0) != 1) GTEST_SKIP() << "soak test: set DFSM_TEST_SOAK=1 to run it";
  const int triggers = EnvInt("DFSM_SOAK_TRIGGERS", 1000);
  const int warm_up = std::max(10, triggers / 100 * 10);  // measured every 10 triggers
  const fs::path dir = fs::temp_directory_path() / ("dfsmd-soak-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  SynthOptions options;  // small frames, so that a thousand jobs take minutes
  options.width = 160;
  options.height = 120;
  options.frames = 24;
  options.supersampling = 2;
  options.seed = 5;
  WriteSynthBurst(dir / "burst", SynthesizeBurst(options));

  // Retention keeps the state directory at a steady size, as in service.
  DfsmdProcess daemon(DFSMD_BINARY,
                      {"--capture.source", "replay:" + (dir / "burst").string(), "--jobs.state_dir",
                       (dir / "state").string(), "--pipeline.dense", "false", "--jobs.queue", "4",
                       "--jobs.retry_after_s", "1", "--retention.max_jobs", "50"},
                      dir / "dfsmd.log");
  ASSERT_TRUE(daemon.ok()) << daemon.Log();
  httplib::Client client = daemon.Client();

  int accepted = 0, refused = 0, succeeded = 0, failed = 0, other = 0;
  std::map<std::string, int> failures;
  std::deque<std::string> running;  // Locations of accepted, unfinished jobs
  ProcessFigures warm, last;
  std::vector<long> rss_samples;
  const auto start = Clock::now();
  Clock::time_point warm_time;
  int measured_at = -1;
  // Polls the oldest running job until it has finished; counts its outcome.
  const auto settle_one = [&] {
    const std::string location = running.front();
    running.pop_front();
    const auto deadline = Clock::now() + std::chrono::seconds(120);
    while (Clock::now() < deadline) {
      auto result = client.Get(location.c_str());
      if (result && result->status == 200) {
        const json job = json::parse(result->body);
        if (job["status"] == "succeeded") return void(++succeeded);
        if (job["status"] == "failed") {
          ++failed;
          ++failures[job.value("error", "")];
          return;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ++other;
    ADD_FAILURE() << location << " did not finish";
  };
  for (int sent = 0; sent < triggers;) {
    auto result = client.Post("/api/v1/captures", R"({"frames":8})", "application/json");
    ASSERT_TRUE(result) << "trigger " << sent << ": " << httplib::to_string(result.error());
    if (result->status == 202) {
      ++accepted, ++sent;
      running.push_back(result->get_header_value("Location"));
    } else {
      ASSERT_EQ(result->status, 503) << result->body;
      EXPECT_FALSE(result->get_header_value("Retry-After").empty());
      ++refused;
      settle_one();  // the queue is full: wait for room, as a client obeying Retry-After would
    }
    if (running.size() >= 6) settle_one();  // more than the queue holds: some 503s
    if ((sent % 10 == 0 || sent == triggers) && sent != measured_at) {
      measured_at = sent;
      // Idle points (nothing queued or running) are where the counts must match.
      while (!running.empty()) settle_one();
      last = MeasureIdle(daemon.pid(), sent > warm_up ? &warm : nullptr);
      rss_samples.push_back(last.rss_kb);
      if (sent == warm_up) {
        warm = last;
        warm_time = Clock::now();
      }
      if (sent > warm_up) {
        EXPECT_LE(last.fds, warm.fds) << "after " << sent << " triggers: " << Print(last);
        EXPECT_LE(last.threads, warm.threads) << "after " << sent << " triggers: " << Print(last);
      }
    }
  }
  while (!running.empty()) settle_one();
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const double growth = 100.0 * (last.peak_rss_kb - warm.peak_rss_kb) / warm.peak_rss_kb;
  const long metric_ok = Metric(client, R"(dfsmd_jobs_total{outcome="succeeded"})");
  const long metric_failed = Metric(client, R"(dfsmd_jobs_total{outcome="failed"})");
  const long metric_rejected = Metric(client, "dfsmd_jobs_rejected_total");

  std::cout << "soak: " << triggers << " triggers in " << seconds << " s ("
            << std::chrono::duration<double>(Clock::now() - warm_time).count()
            << " s after warm-up), " << accepted << " accepted, " << refused
            << " refused with 503 (retried), " << succeeded << " succeeded, " << failed
            << " failed, " << other << " unaccounted\n"
            << "soak: metrics: succeeded " << metric_ok << ", failed " << metric_failed
            << ", rejected " << metric_rejected << "\n"
            << "soak: warm-up (" << warm_up << " triggers): " << Print(warm) << "\n"
            << "soak: end: " << Print(last) << "\n"
            << "soak: peak RSS growth after warm-up: " << growth << " %\n";
  for (const auto& [reason, count] : failures)
    std::cout << "soak: failed " << count << "x: " << reason << "\n";
  std::cout << "soak: rss samples (kB, every 10 triggers):";
  for (const long rss : rss_samples) std::cout << " " << rss;
  std::cout << "\n";

  EXPECT_EQ(accepted, triggers);
  EXPECT_EQ(succeeded + failed, accepted);
  EXPECT_EQ(other, 0);
  EXPECT_EQ(metric_ok, succeeded);
  EXPECT_EQ(metric_failed, failed);
  EXPECT_EQ(metric_rejected, refused);
  // The burst is good: at most a stray failure (a replay seam timing out), never a trend.
  EXPECT_GE(succeeded, accepted * 95 / 100);
  EXPECT_LT(growth, 5.0);
  EXPECT_LE(last.fds, warm.fds);
  EXPECT_LE(last.threads, warm.threads);
  EXPECT_EQ(daemon.Stop(SIGTERM), 0) << daemon.Log();
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace dfsm::test
