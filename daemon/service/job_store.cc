#include "daemon/service/job_store.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>

#include "core/io/file_util.h"
#include "daemon/log/log.h"
#include "daemon/service/retention.h"

namespace dfsm::service {
namespace fs = std::filesystem;

namespace {

constexpr const char* kRecordFile = "job.json";

}  // namespace

JobStore::JobStore(fs::path state_dir) : state_dir_(std::move(state_dir)) {
  std::error_code error;
  for (const char* sub : {"jobs", "tmp"}) {
    fs::create_directories(state_dir_ / sub, error);
    if (error) {
      throw JobStoreError("state directory '" + (state_dir_ / sub).string() +
                          "' cannot be created: " + error.message());
    }
  }
  if (::access(state_dir_.c_str(), W_OK) != 0) {
    throw JobStoreError("state directory '" + state_dir_.string() + "' is not writable");
  }
  // Leftovers of an interrupted upload, capture or output: never acknowledged
  // to anyone, or superseded by a re-run.
  for (const auto& entry : fs::directory_iterator(state_dir_ / "tmp")) {
    fs::remove_all(entry.path(), error);
  }
  for (const auto& entry : fs::directory_iterator(state_dir_ / "jobs")) {
    const std::string name = entry.path().filename().string();
    try {
      if (!IsValidJobId(name)) throw std::invalid_argument("not a job id");
      Job job = JobFromJson(nlohmann::json::parse(ReadFileToString(entry.path() / kRecordFile)));
      if (job.id != name) throw std::invalid_argument("record names job " + job.id);
      job.has_burst = fs::exists(entry.path() / "burst" / "manifest.json");
      // A record being replaced when the previous run died (job.json.tmp.<pid>).
      for (const auto& file : fs::directory_iterator(entry.path())) {
        if (file.path().filename().string().rfind(std::string(kRecordFile) + ".tmp.", 0) == 0)
          fs::remove(file.path(), error);
      }
      jobs_.emplace(job.id, job);
      newest_id_ = std::max(newest_id_, job.id);
    } catch (const std::exception& e) {
      const fs::path aside = state_dir_ / "damaged" / name;
      log::Error("job directory '" + entry.path().string() + "' is damaged (" + e.what() +
                 "); moved to " + aside.string());
      fs::create_directories(aside.parent_path(), error);
      fs::rename(entry.path(), aside, error);
    }
  }
}

fs::path JobStore::NewStagingDir() {
  std::lock_guard<std::mutex> lock(mutex_);
  const fs::path dir =
      state_dir_ / "tmp" /
      ("stage-" + std::to_string(::getpid()) + "-" + std::to_string(++staging_counter_));
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) throw JobStoreError("cannot create '" + dir.string() + "': " + error.message());
  return dir;
}

std::string JobStore::NewIdLocked() {
  int64_t ms = NowUnixMs();
  unsigned sequence = 0;
  long long newest_ms = 0;
  unsigned newest_sequence = 0;
  if (!newest_id_.empty() &&
      std::sscanf(newest_id_.c_str(), "j%13lld-%4x", &newest_ms, &newest_sequence) == 2 &&
      ms <= newest_ms) {
    ms = newest_ms;
    sequence = newest_sequence + 1;
    if (sequence > 0xffff) {
      ++ms;
      sequence = 0;
    }
  }
  char id[32];
  std::snprintf(id, sizeof(id), "j%013lld-%04x", static_cast<long long>(ms), sequence);
  newest_id_ = id;
  return newest_id_;
}

Job JobStore::Create(const std::string& origin, const JobOptions& options,
                     const fs::path& staged_burst, const nlohmann::json& input) {
  // The job directory is assembled in tmp/ (record + burst) and appears in
  // jobs/ with one rename.
  const fs::path assembly = NewStagingDir();
  std::error_code moved;
  if (!staged_burst.empty()) fs::rename(staged_burst, assembly / "burst", moved);
  if (moved) {
    std::error_code ignored;
    fs::remove_all(assembly, ignored);
    throw JobStoreError("cannot store the burst in '" + assembly.string() +
                        "': " + moved.message());
  }
  std::lock_guard<std::mutex> lock(mutex_);
  Job job;
  job.id = NewIdLocked();
  job.origin = origin;
  job.options = options;
  job.created_ms = NowUnixMs();
  job.has_burst = !staged_burst.empty();
  job.input = input;
  try {
    WriteRecord(assembly, job);
  } catch (const JobStoreError&) {
    // Disk full: the staged burst must not keep the space until the next start.
    std::error_code ignored;
    fs::remove_all(assembly, ignored);
    throw;
  }
  std::error_code error;
  fs::rename(assembly, JobDir(job.id), error);
  if (error) {
    fs::remove_all(assembly);
    throw JobStoreError("cannot store job " + job.id + ": " + error.message());
  }
  SyncJobs();
  jobs_.emplace(job.id, job);
  ChangedLocked();
  return job;
}

bool JobStore::AttachBurst(const std::string& id, const fs::path& staged_burst) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return false;
  std::error_code error;
  fs::rename(staged_burst, BurstDir(id), error);
  if (error) throw JobStoreError("cannot store the burst of job " + id + ": " + error.message());
  try {
    SyncDirectory(JobDir(id));
  } catch (const std::exception& e) {
    throw JobStoreError(e.what());
  }
  Job& job = it->second;
  job.has_burst = true;
  // A job that finished first counted its bytes without the burst.
  if (IsFinished(job.status)) job.bytes += DirectoryBytes(BurstDir(id));
  WriteRecord(JobDir(id), job);
  ChangedLocked();
  return true;
}

void JobStore::SyncJobs() const {
  try {
    SyncDirectory(state_dir_ / "jobs");
  } catch (const std::exception& e) {
    throw JobStoreError(e.what());
  }
}

std::optional<Job> JobStore::Get(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return it->second;
}

std::vector<Job> JobStore::List() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Job> jobs;
  for (auto it = jobs_.rbegin(); it != jobs_.rend(); ++it) jobs.push_back(it->second);
  return jobs;
}

std::vector<Job> JobStore::Unfinished() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Job> jobs;
  for (const auto& [id, job] : jobs_) {
    if (!IsFinished(job.status)) jobs.push_back(job);
  }
  return jobs;
}

std::optional<Job> JobStore::LatestSucceeded() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const Job* latest = nullptr;
  for (const auto& [id, job] : jobs_) {
    if (job.status == JobStatus::kSucceeded &&
        (!latest || job.finished_ms >= latest->finished_ms)) {
      latest = &job;
    }
  }
  if (!latest) return std::nullopt;
  return *latest;
}

void JobStore::Update(const Job& job) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = jobs_.find(job.id);
  if (it == jobs_.end()) throw JobStoreError("unknown job " + job.id);
  Job stored = job;
  stored.has_burst = it->second.has_burst;
  // The caller's copy may predate the progress reported since (SetProgress).
  if (job.status == JobStatus::kProcessing && it->second.status == JobStatus::kProcessing &&
      job.attempts == it->second.attempts)
    stored.progress = std::max(job.progress, it->second.progress);
  ChangedLocked();
  // A finished job's bytes are counted here, under the lock AttachBurst
  // takes: counted by the caller, a burst attached between the count and
  // this update would be missed by both (AttachBurst adds it only to a job
  // already finished), and retention would under-count it.
  if (IsFinished(stored.status))
    stored.bytes = DirectoryBytes(BurstDir(job.id)) + DirectoryBytes(OutputDir(job.id));
  try {
    WriteRecord(JobDir(job.id), stored);
  } catch (const JobStoreError&) {
    // Clients see the job as it is (failed, say, because the disk is full)
    // rather than a stage that never ends; the record on disk still says what
    // it said before, so a restart re-runs the job.
    it->second = stored;
    throw;
  }
  it->second = stored;
}

void JobStore::SetProgress(const std::string& id, const std::string& stage, double progress) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end() || it->second.status != JobStatus::kProcessing) return;
  it->second.stage = stage;
  it->second.progress = std::clamp(std::max(progress, it->second.progress), 0.0, 1.0);
  ChangedLocked();
}

uint64_t JobStore::WaitForChange(uint64_t seen, std::chrono::milliseconds timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return changes_ != seen; });
  return changes_;
}

void JobStore::ChangedLocked() {
  ++changes_;
  changed_.notify_all();
}

void JobStore::CommitOutput(const std::string& id, const fs::path& staged_output) {
  const fs::path target = OutputDir(id);
  std::error_code error;
  if (fs::exists(target)) Discard(target);
  fs::rename(staged_output, target, error);
  if (error) throw JobStoreError("cannot store the output of job " + id + ": " + error.message());
  try {
    SyncDirectory(JobDir(id));
  } catch (const std::exception& e) {
    throw JobStoreError(e.what());
  }
}

void JobStore::DropBurst(const std::string& id) {
  const fs::path burst = BurstDir(id);
  if (fs::exists(burst)) Discard(burst);
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = jobs_.find(id);
  if (it != jobs_.end()) it->second.has_burst = false;
  ChangedLocked();
}

bool JobStore::Remove(const std::string& id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!jobs_.erase(id)) return false;
    ChangedLocked();
  }
  Discard(JobDir(id));
  return true;
}

std::vector<std::string> JobStore::EnforceRetention(const RetentionSection& limits,
                                                    int64_t now_ms) {
  const std::vector<std::string> expired = SelectExpiredJobs(List(), limits, now_ms);
  for (const std::string& id : expired) Remove(id);
  return expired;
}

std::string WithoutDirectory(std::string message, const fs::path& dir, const std::string& name) {
  const std::string prefix = dir.string() + "/";
  for (size_t at = message.find(prefix); at != std::string::npos; at = message.find(prefix, at))
    message.erase(at, prefix.size());
  const std::string bare = dir.string();
  for (size_t at = message.find(bare); at != std::string::npos; at = message.find(bare, at))
    message.replace(at, bare.size(), name);
  return message;
}

fs::path JobStore::JobDir(const std::string& id) const { return state_dir_ / "jobs" / id; }
fs::path JobStore::BurstDir(const std::string& id) const { return JobDir(id) / "burst"; }
fs::path JobStore::OutputDir(const std::string& id) const { return JobDir(id) / "output"; }

void JobStore::WriteRecord(const fs::path& job_dir, const Job& job) const {
  try {
    WriteFileAtomically(job_dir / kRecordFile, ToJson(job).dump(2) + "\n");
  } catch (const std::exception& e) {
    throw JobStoreError(e.what());
  }
}

void JobStore::Discard(const fs::path& dir) {
  fs::path trash;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    trash = state_dir_ / "tmp" / ("trash-" + std::to_string(++staging_counter_));
  }
  std::error_code error;
  fs::rename(dir, trash, error);
  fs::remove_all(error ? dir : trash, error);
}

int64_t JobStore::DirectoryBytes(const fs::path& dir) {
  int64_t bytes = 0;
  std::error_code error;
  for (auto it = fs::recursive_directory_iterator(dir, error); !error && it != fs::end(it);
       it.increment(error)) {
    if (it->is_regular_file(error)) bytes += static_cast<int64_t>(it->file_size(error));
  }
  return bytes;
}

}  // namespace dfsm::service
