// Stores captured bursts in their jobs in the background. A capture is
// answered (202) as soon as its frames are out of the ring and its job is
// recorded; encoding ten 1080p frames as PNG takes longer than the answer may
// (issue: one shape from camera to result), so it happens here, beside the
// pipeline that runs on the frames in memory.
//
// Invariants:
//  - A burst appears in its job whole or not at all: it is written under the
//    store's tmp/, flushed once (WriteBurst) and renamed in (AttachBurst,
//    which records has_burst). A job may finish before its burst is stored;
//    has_burst turns true when it is.
//  - The writer is one thread encoding one frame after another: the job's
//    pipeline keeps the other cores.
//  - The destructor writes every burst still queued: a queued job survives a
//    clean stop. Only a crash before a burst is written loses it; the job is
//    then failed at the next start, saying so (JobProcessor).
// Thread-safe.
#pragma once

#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <thread>

#include "daemon/service/camera_port.h"
#include "daemon/service/job_store.h"

namespace dfsm::service {

class BurstPersister {
 public:
  explicit BurstPersister(JobStore* store);
  ~BurstPersister();  // writes what is queued, then joins
  BurstPersister(const BurstPersister&) = delete;
  BurstPersister& operator=(const BurstPersister&) = delete;

  // Queues `burst` for job `id` (created without one).
  void Enqueue(const std::string& id, CameraBurst burst);

  // Job `id` has no use for its burst (deleted, or succeeded without
  // keep_burst): a burst still queued is dropped unwritten; one being written
  // is waited for, so that it is attached (or has failed, logged) before this
  // returns. Returns at once for a job with nothing queued or being written.
  void Drop(const std::string& id);

  // Bursts queued or being written.
  int Pending() const;

 private:
  struct Entry {
    std::string id;
    CameraBurst burst;
  };
  void Loop();
  // Writes and attaches one burst; a failure is logged (the job then has no
  // burst: has_burst stays false).
  void Store(const Entry& entry);

  JobStore* const store_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Entry> queue_;
  std::string writing_;  // id being written, empty when none
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace dfsm::service
