// A bounded queue of job ids and the worker threads that drain it. It knows
// nothing of the pipeline: each job is handed to the `Work` function.
//
// Invariants: at most `capacity` jobs wait (queued + reserved) unless jobs were
// recovered at start-up, which are never refused; at most `workers` run at
// once; nothing here blocks the caller of TryReserve/Submit.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "core/io/burst.h"

namespace dfsm::service {

class JobScheduler {
 public:
  // `burst` is the decoded input when the submitter already has it in memory
  // (a fresh capture or upload), null when the worker must read it from disk.
  using Work = std::function<void(const std::string& id, std::shared_ptr<const Burst> burst)>;

  // A place in the queue, held while a request prepares its job (grabs the
  // frames, stores the burst). Released on destruction unless submitted.
  class Reservation {
   public:
    Reservation(Reservation&& other) noexcept : scheduler_(other.scheduler_) {
      other.scheduler_ = nullptr;
    }
    Reservation& operator=(Reservation&&) = delete;
    ~Reservation();

   private:
    friend class JobScheduler;
    explicit Reservation(JobScheduler* scheduler) : scheduler_(scheduler) {}
    JobScheduler* scheduler_;
  };

  JobScheduler(int workers, int capacity, Work work);
  ~JobScheduler();  // Shutdown()
  JobScheduler(const JobScheduler&) = delete;
  JobScheduler& operator=(const JobScheduler&) = delete;

  void Start();
  // Refuses new work, lets running jobs finish and joins the workers. Queued
  // jobs stay queued (they are on disk and resume at the next start).
  void Shutdown();

  // nullopt when the queue is full (or shutting down).
  std::optional<Reservation> TryReserve();
  void Submit(Reservation reservation, const std::string& id, std::shared_ptr<const Burst> burst);
  // For jobs found unfinished at start-up: queued whatever the capacity.
  void SubmitRecovered(const std::string& id);

  // Takes a queued (not running) job out of the queue; false when not queued.
  bool RemoveQueued(const std::string& id);
  bool IsRunning(const std::string& id) const;

  int Depth() const;  // queued + reserved
  int Running() const;
  // Whether jobs are queued or running and none has started or finished for
  // `limit` since the workers started: the queue cannot drain.
  bool Stalled(std::chrono::steady_clock::duration limit) const;
  int capacity() const { return capacity_; }
  bool Full() const { return Depth() >= capacity_; }

 private:
  struct Entry {
    std::string id;
    std::shared_ptr<const Burst> burst;
  };
  void WorkerLoop();
  void Release();

  const int workers_count_;
  const int capacity_;
  const Work work_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Entry> queue_;
  int reserved_ = 0;
  std::set<std::string> running_;
  // When a job last started or finished (or the workers started).
  std::chrono::steady_clock::time_point progress_ = std::chrono::steady_clock::now();
  bool started_ = false;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace dfsm::service
