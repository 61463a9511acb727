// Fuzzes the burst upload of POST /api/v1/jobs below HTTP: the ustar reader
// (daemon/service/ustar.h) on its own, then JobIntake::FromArchive on a real
// job store, which extracts the archive to disk, reads the burst (manifest and
// PNG frames) and stores a queued job. The scheduler is never started, so no
// pipeline runs; every accepted job is deleted again so the store stays small.
// Bad archives must be TarError / BadUpload with a message; nothing may be
// written outside the store, and nothing half-made may stay in its tmp/.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>

#include "daemon/service/job_intake.h"
#include "fuzz/fuzz_check.h"
#include "fuzz/state_dir.h"

namespace {

namespace fs = std::filesystem;
using namespace dfsm::service;

// Small limits (the daemon's come from [limits]), so that no input can make
// the fuzzer slow by being or decoding large.
TarLimits FuzzLimits() {
  TarLimits limits;
  limits.max_entries = 64;
  limits.max_file_bytes = 1 << 20;
  limits.max_total_bytes = 4 << 20;
  return limits;
}

BurstLimits FuzzBurstLimits() {
  BurstLimits limits;
  limits.max_frames = 32;
  limits.max_frame_pixels = 256 * 256;
  limits.max_burst_pixels = 1 << 20;
  return limits;
}

struct Intake {
  dfsm::fuzz::StateDir dir{"tar"};
  Metrics metrics;
  JobStore store{dir.path()};
  JobScheduler scheduler{1, 4, [](const std::string&, std::shared_ptr<const dfsm::Burst>) {}};
  JobIntake intake{&store, &scheduler, nullptr, &metrics, FuzzLimits(), FuzzBurstLimits()};
};

// What ReadTar promises of the names it returns: relative, normalized, unique.
void CheckEntries(const std::vector<TarEntry>& entries, const TarLimits& limits) {
  FUZZ_CHECK(!entries.empty(), "an empty archive was accepted");
  FUZZ_CHECK(static_cast<int>(entries.size()) <= limits.max_entries, "too many entries");
  std::map<std::string, std::string_view> files;
  for (const TarEntry& entry : entries) {
    const std::string& path = entry.path;
    FUZZ_CHECK(!path.empty() && path.front() != '/' && path.back() != '/', "bad name " + path);
    FUZZ_CHECK(("/" + path + "/").find("/../") == std::string::npos, "'..' in " + path);
    FUZZ_CHECK(("/" + path + "/").find("/./") == std::string::npos, "'.' in " + path);
    FUZZ_CHECK(path.find("//") == std::string::npos, "empty component in " + path);
    FUZZ_CHECK(static_cast<int64_t>(entry.data.size()) <= limits.max_file_bytes, "file too big");
    if (!entry.is_directory) files.emplace(path, entry.data);
  }
  // Regular files survive a write/read round trip (GET .../burst.tar writes them).
  std::vector<TarFile> written;
  for (const auto& [path, data] : files) written.push_back({path, std::string(data)});
  const std::string archive = WriteTar(written);
  const std::vector<TarEntry> again = ReadTar(archive, limits);
  FUZZ_CHECK(again.size() == written.size(), "round trip changed the number of files");
  for (const TarEntry& entry : again) {
    const auto found = files.find(entry.path);
    FUZZ_CHECK(found != files.end() && found->second == entry.data,
               "round trip changed " + entry.path);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Intake intake;  // one store per process; removed at exit
  Intake* const state = &intake;
  const std::string_view archive(reinterpret_cast<const char*>(data), size);

  try {
    CheckEntries(ReadTar(archive, FuzzLimits()), FuzzLimits());
  } catch (const TarError& error) {
    dfsm::fuzz::CheckNamedError(error);
  }

  JobOptions options;
  options.frames = 0;  // every frame of the upload, as POST /api/v1/jobs without ?frames
  try {
    const Job job = state->intake.FromArchive(archive, options);
    FUZZ_CHECK(state->store.Get(job.id).has_value(), "accepted job " + job.id + " is not stored");
    FUZZ_CHECK(fs::is_regular_file(state->store.BurstDir(job.id) / "manifest.json"),
               "accepted job " + job.id + " has no manifest.json");
    FUZZ_CHECK(state->scheduler.RemoveQueued(job.id), "accepted job " + job.id + " not queued");
    state->store.Remove(job.id);
  } catch (const BadUpload& error) {
    dfsm::fuzz::CheckNamedError(error);
  }
  FUZZ_CHECK(fs::is_empty(state->dir.path() / "tmp"), "staging left behind in tmp/");
  FUZZ_CHECK(fs::is_empty(state->dir.path() / "jobs"), "a rejected upload left a job directory");
  return 0;
}
