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
#include <map>
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

  // Waits until job `id`'s burst is stored or has failed. With `needed` false
  // a burst not yet begun is dropped instead (a job that succeeded without
  // keep_burst has no use for it). Returns the error of a failed write (also
  // logged), empty when stored, dropped, or never queued.
  std::string Settle(const std::string& id, bool needed);

  // Bursts queued or being written.
  int Pending() const;

 private:
  struct Entry {
    std::string id;
    CameraBurst burst;
  };
  void Loop();
  std::string Store(const Entry& entry);

  JobStore* const store_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Entry> queue_;
  std::string writing_;                         // id being written, empty when none
  std::map<std::string, std::string> settled_;  // id -> error, until Settle() takes it
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace dfsm::service
