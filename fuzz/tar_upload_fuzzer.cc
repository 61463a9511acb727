// Fuzzes the burst upload of POST /api/v1/jobs below HTTP: the tar reader
// (daemon/service/tar_extract.h: libarchive under dfsm's policy) on its own,
// then JobIntake::FromArchive (the same reader, fed through a pipe) on a real
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

#include "core/io/file_util.h"
#include "daemon/service/job_intake.h"
#include "daemon/service/tar_extract.h"
#include "daemon/service/tar_writer.h"
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
  JobIntake intake{&store, &scheduler, nullptr, nullptr, &metrics, FuzzLimits(), FuzzBurstLimits()};
};

// What ExtractTar wrote: plain files and directories within the limits, which
// GET .../burst.tar (DirectoryTar) sends so that they extract the same again.
void CheckExtracted(const fs::path& dir, const fs::path& again, const TarLimits& limits) {
  std::string archive;
  DirectoryTar tar(dir);
  for (std::string piece = tar.Next(); !piece.empty(); piece = tar.Next()) archive += piece;
  fs::create_directories(again);
  ExtractTar(archive, again, limits);
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const fs::path copy = again / entry.path().lexically_relative(dir);
    FUZZ_CHECK(!entry.is_symlink() && (entry.is_regular_file() || entry.is_directory()),
               "not a plain file or directory: " + copy.string());
    FUZZ_CHECK(!entry.is_regular_file() ||
                   (static_cast<int64_t>(entry.file_size()) <= limits.max_file_bytes &&
                    dfsm::ReadFileToString(copy) == dfsm::ReadFileToString(entry.path())),
               "too big, or changed by the round trip: " + copy.string());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Intake intake;  // one store per process; removed at exit
  Intake* const state = &intake;
  const std::string_view archive(reinterpret_cast<const char*>(data), size);

  const fs::path out = state->dir.path() / "extract", again = state->dir.path() / "again";
  fs::create_directories(out);
  try {
    ExtractTar(archive, out, FuzzLimits());
    CheckExtracted(out, again, FuzzLimits());
  } catch (const TarError& error) {
    dfsm::fuzz::CheckNamedError(error);
  }
  fs::remove_all(out);
  fs::remove_all(again);

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
