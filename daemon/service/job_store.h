// The jobs on disk: one directory per job under <state_dir>/jobs, holding
// job.json (the record), burst/ (the input, dfsm-burst/1) and output/ (the
// dfsm-result/1 directory). Together the job.json files are the job index: it
// is rebuilt from them at start-up, so it survives restarts and crashes.
//
// Invariants:
//  - A job directory appears complete or not at all: it is assembled under
//    <state_dir>/tmp and renamed into jobs/ (rename(2) is atomic on one file
//    system). The same holds for output/.
//  - job.json is always replaced atomically (temp file + rename).
//  - tmp/ holds nothing of value: it is emptied at start-up.
// Thread-safe: every method may be called from any thread.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "daemon/service/config.h"
#include "daemon/service/job.h"

namespace dfsm::service {

// `message` with every path under `dir` written relative to it, and `dir`
// itself written `name`: a client named its files relative to its burst, and
// the daemon's state directory is none of its business.
std::string WithoutDirectory(std::string message, const std::filesystem::path& dir,
                             const std::string& name);

class JobStoreError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class JobStore {
 public:
  // Creates the layout when missing, empties tmp/ and loads every job.json.
  // A damaged job directory is moved aside to <state_dir>/damaged (never
  // deleted: it may hold a capture) and logged. Throws JobStoreError when the
  // directory cannot be used at all.
  explicit JobStore(std::filesystem::path state_dir);

  const std::filesystem::path& state_dir() const { return state_dir_; }

  // A fresh, empty directory under tmp/ for assembling a burst or an output.
  std::filesystem::path NewStagingDir();

  // Makes a queued job from a complete burst in `staged_burst` (a directory
  // from NewStagingDir(), consumed), or without a burst when `staged_burst` is
  // empty (a capture whose burst is stored afterwards: AttachBurst). Returns
  // the stored record.
  Job Create(const std::string& origin, const JobOptions& options,
             const std::filesystem::path& staged_burst, const nlohmann::json& input);
  // Moves a complete burst (`staged_burst`, consumed) into a job created
  // without one, makes the rename durable and records has_burst (and, for a
  // job already finished, the burst's bytes). False when the job is gone.
  // Throws JobStoreError.
  bool AttachBurst(const std::string& id, const std::filesystem::path& staged_burst);

  std::optional<Job> Get(const std::string& id) const;
  // Newest first.
  std::vector<Job> List() const;
  // Jobs left queued or processing by the previous run, oldest first.
  std::vector<Job> Unfinished() const;
  // The newest job that succeeded (by finish time), if any.
  std::optional<Job> LatestSucceeded() const;

  // Replaces the stored record (same id). has_burst is the store's own (set
  // by Create, AttachBurst and DropBurst), whatever `job` says; so are the
  // bytes of a finished job (its burst and output, counted here). Throws
  // JobStoreError for an unknown id, or when the record cannot be written
  // (then the job is updated in memory only).
  void Update(const Job& job);

  // Sets a processing job's stage and progress (0..1) in memory only: they
  // are news for clients, not state worth an fsync (a restarted job starts
  // over anyway). The progress of one run never goes back.
  void SetProgress(const std::string& id, const std::string& stage, double progress);

  // Waits until the jobs change (one created, updated, progressed, removed)
  // after the change count `seen`, or `timeout` passes; returns the count.
  uint64_t WaitForChange(uint64_t seen, std::chrono::milliseconds timeout) const;

  // Replaces <job>/output with `staged_output` (a directory from NewStagingDir()).
  void CommitOutput(const std::string& id, const std::filesystem::path& staged_output);
  // Deletes <job>/burst (keep_burst false, after success); has_burst becomes
  // false with the next Update.
  void DropBurst(const std::string& id);
  // Deletes the job. Returns false for an unknown id. The caller makes sure the
  // job is not in flight.
  bool Remove(const std::string& id);

  // Removes the finished jobs that SelectExpiredJobs picks; returns their ids.
  // Queued and processing jobs are never touched.
  std::vector<std::string> EnforceRetention(const RetentionSection& limits, int64_t now_ms);

  std::filesystem::path BurstDir(const std::string& id) const;
  std::filesystem::path OutputDir(const std::string& id) const;

  // Bytes under a directory (regular files).
  static int64_t DirectoryBytes(const std::filesystem::path& dir);

 private:
  std::filesystem::path JobDir(const std::string& id) const;
  void WriteRecord(const std::filesystem::path& job_dir, const Job& job) const;
  // fsync of jobs/: a job directory renamed in survives a power cut.
  void SyncJobs() const;
  // j<Unix ms>-<sequence within the ms, hex>, after newest_id_; mutex_ held.
  std::string NewIdLocked();
  // Moves a directory into tmp/ (atomic, instant) and deletes it from there.
  void Discard(const std::filesystem::path& dir);
  // Counts a change and wakes WaitForChange; mutex_ held.
  void ChangedLocked();

  const std::filesystem::path state_dir_;
  mutable std::mutex mutex_;
  std::map<std::string, Job> jobs_;  // by id, i.e. by creation time
  uint64_t changes_ = 0;
  mutable std::condition_variable changed_;
  uint64_t staging_counter_ = 0;
  // The greatest id issued or found: a new id sorts after it, so that ids
  // sort by creation even within one millisecond or after the clock is set
  // back.
  std::string newest_id_;
};

}  // namespace dfsm::service
