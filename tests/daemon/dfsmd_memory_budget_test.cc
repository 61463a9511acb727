// The 1 GB board profile inside a real memory cgroup (label daemon; the
// embedded issue's item 4): dfsmd with config/dfsmd-1gb.toml and the
// environment and MemoryMax= of its drop-in systemd/dfsmd-1gb.conf, read from
// those files, streams a 1080p replay and runs three 10-frame jobs. Every job
// must succeed and the kernel must never have had to kill inside the cgroup.
//
// systemd-run needs systemd as PID 1, which a build container lacks, so the
// test makes the cgroup itself: cgroup v2's memory.max where the unified
// hierarchy has the memory controller, else v1's memory.limit_in_bytes. It
// skips, saying why, where neither can be written (not root, a read-only
// /sys/fs/cgroup) and under a sanitizer (its shadow memory is not dfsmd's).
#include <gtest/gtest.h>
#include <signal.h>

#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <regex>

#include "core/io/file_util.h"
#include "core/synth/burst_synthesizer.h"
#include "tests/daemon/fault_helpers.h"

namespace dfsm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif

// What a systemd drop-in sets: MemoryMax= in bytes (systemd's K/M/G/T are
// powers of 1024) and each Environment= assignment.
struct DropIn {
  int64_t memory_max = -1;
  std::map<std::string, std::string> environment;
};

DropIn ReadDropIn(const fs::path& file) {
  DropIn drop_in;
  std::istringstream text(ReadFileToString(file));
  const std::regex memory_max(R"(^MemoryMax=(\d+)([KMGT]?)\s*$)");
  const std::regex environment(R"(^Environment=([A-Za-z_][A-Za-z0-9_]*)=(\S*)\s*$)");
  for (std::string line; std::getline(text, line);) {
    std::smatch match;
    if (std::regex_match(line, match, memory_max)) {
      const std::string units = "KMGT";
      const size_t power = match[2].str().empty() ? 0 : units.find(match[2].str()) + 1;
      drop_in.memory_max = std::stoll(match[1].str()) << (10 * power);
    } else if (std::regex_match(line, match, environment)) {
      drop_in.environment[match[1].str()] = match[2].str();
    }
  }
  return drop_in;
}

std::string ReadLine(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  return line;
}

bool WriteValue(const fs::path& file, const std::string& value) {
  std::ofstream out(file);
  out << value;
  out.flush();
  return static_cast<bool>(out);
}

// VmHWM of `pid` in bytes, -1 where /proc does not tell.
int64_t PeakRss(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) return std::stoll(line.substr(6)) * 1024;
  return -1;
}

// "key N" from a flat-keyed cgroup file (memory.events, memory.oom_control).
int64_t KeyedValue(const fs::path& file, const std::string& key) {
  std::ifstream in(file);
  for (std::string name, value; in >> name >> value;)
    if (name == key) return std::stoll(value);
  return -1;
}

// A memory cgroup of its own for as long as this lives.
class MemoryCgroup {
 public:
  MemoryCgroup(const std::string& name, int64_t limit) {
    const fs::path v2 = "/sys/fs/cgroup";
    const fs::path v1 = "/sys/fs/cgroup/memory";
    if (ReadFileContains(v2 / "cgroup.controllers", "memory")) {
      v2_ = true;
      dir_ = v2 / name;
    } else if (fs::exists(v1 / "memory.limit_in_bytes")) {
      dir_ = v1 / name;
    } else {
      why_ = "no memory cgroup controller under /sys/fs/cgroup (v2 or v1)";
      return;
    }
    std::error_code error;
    fs::create_directory(dir_, error);
    const bool limited =
        !error &&
        (v2_ ? WriteValue(dir_ / "memory.max", std::to_string(limit)) &&
                   (!fs::exists(dir_ / "memory.swap.max") ||
                    WriteValue(dir_ / "memory.swap.max", "0"))
             : WriteValue(dir_ / "memory.limit_in_bytes", std::to_string(limit)) &&
                   (!fs::exists(dir_ / "memory.memsw.limit_in_bytes") ||
                    WriteValue(dir_ / "memory.memsw.limit_in_bytes", std::to_string(limit))));
    if (!limited) {
      why_ = "cannot create the memory cgroup " + dir_.string() + " and set its limit (" +
             (error ? error.message() : "write refused") + "): the test needs root";
      fs::remove(dir_, error);
      dir_.clear();
    }
  }
  ~MemoryCgroup() {
    if (dir_.empty()) return;
    std::error_code error;
    for (int i = 0; i < 50 && !fs::remove(dir_, error); ++i)  // the last process may still exit
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  bool ok() const { return !dir_.empty(); }
  const std::string& why() const { return why_; }
  fs::path procs() const { return dir_ / "cgroup.procs"; }

  // The most memory the cgroup was charged; -1 where the kernel does not tell
  // (v2 before Linux 5.19).
  int64_t peak() const {
    const std::string line = ReadLine(dir_ / (v2_ ? "memory.peak" : "memory.max_usage_in_bytes"));
    return line.empty() ? -1 : std::stoll(line);
  }
  // Processes the kernel killed for this cgroup's limit.
  int64_t oom_kills() const {
    return KeyedValue(dir_ / (v2_ ? "memory.events" : "memory.oom_control"), "oom_kill");
  }

 private:
  static bool ReadFileContains(const fs::path& file, const std::string& word) {
    std::ifstream in(file);
    for (std::string token; in >> token;)
      if (token == word) return true;
    return false;
  }

  bool v2_ = false;
  fs::path dir_;
  std::string why_;
};

TEST(DfsmdMemoryBudget, TheOneGigabyteProfileRunsA1080pJobInsideItsMemoryMax) {
  if (kSanitized) GTEST_SKIP() << "under a sanitizer the peak is its shadow memory, not dfsmd's";
  const fs::path source = DFSM_SOURCE_DIR;
  const DropIn drop_in = ReadDropIn(source / "systemd/dfsmd-1gb.conf");
  ASSERT_GT(drop_in.memory_max, 0) << "systemd/dfsmd-1gb.conf sets no MemoryMax=";
  MemoryCgroup cgroup("dfsmd-memory-budget-" + std::to_string(::getpid()), drop_in.memory_max);
  if (!cgroup.ok()) GTEST_SKIP() << cgroup.why();

  const fs::path root =
      fs::temp_directory_path() / ("dfsmd-memory-budget-" + std::to_string(::getpid()));
  fs::remove_all(root);
  SynthOptions options;  // 1920x1080, 10 frames
  options.seed = 1;
  WriteSynthBurst(root / "burst", SynthesizeBurst(options));
  fs::create_directories(root / "state");

  // The shell puts itself into the cgroup and becomes dfsmd (same pid), so
  // every byte dfsmd ever allocates is charged there; DfsmdProcess appends
  // --server.port to "$@".
  const std::vector<std::string> args = {
      "-c",
      "echo $$ > '" + cgroup.procs().string() + "' && exec \"$0\" \"$@\"",
      DFSMD_BINARY,
      "--config",
      (source / "config/dfsmd-1gb.toml").string(),
      "--capture.source",
      "replay:" + (root / "burst").string(),
      "--jobs.state_dir",
      (root / "state").string()};
  {
    DfsmdProcess daemon("/bin/sh", args, root / "dfsmd.log", drop_in.environment);
    ASSERT_TRUE(daemon.ok()) << daemon.Log();
    httplib::Client client = daemon.Client();
    client.set_read_timeout(std::chrono::seconds(60));
    for (int job = 0; job < 3; ++job) {
      const std::string location =
          AcceptedLocation(client.Post("/api/v1/captures", "{}", "application/json"));
      ASSERT_FALSE(location.empty()) << daemon.Log();
      const json finished = AwaitFinished(client, location, std::chrono::seconds(300));
      EXPECT_EQ(finished["status"], "succeeded") << finished.dump() << daemon.Log();
    }
    // The cgroup's charge counts the page cache of the burst and results too
    // (reclaimed before anything is killed); VmHWM is dfsmd's own peak.
    std::cout << "1 GB profile, 1920x1080, 3 jobs: dfsmd peak RSS "
              << PeakRss(daemon.pid()) / (1 << 20) << " MiB, cgroup peak charge "
              << cgroup.peak() / (1 << 20) << " MiB of MemoryMax " << drop_in.memory_max / (1 << 20)
              << " MiB, " << cgroup.oom_kills() << " OOM kills\n";
    EXPECT_EQ(cgroup.oom_kills(), 0);
    EXPECT_EQ(daemon.Stop(SIGTERM), 0) << daemon.Log();
  }
  fs::remove_all(root);
}

}  // namespace
}  // namespace dfsm::test
