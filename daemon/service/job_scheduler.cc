#include "daemon/service/job_scheduler.h"

#include <algorithm>

namespace dfsm::service {

JobScheduler::Reservation::~Reservation() {
  if (scheduler_) scheduler_->Release();
}

JobScheduler::JobScheduler(int workers, int capacity, Work work)
    : workers_count_(workers), capacity_(capacity), work_(std::move(work)) {}

JobScheduler::~JobScheduler() { Shutdown(); }

void JobScheduler::Start() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!workers_.empty() || stopping_) return;
  progress_ = std::chrono::steady_clock::now();
  started_ = true;
  for (int i = 0; i < workers_count_; ++i) workers_.emplace_back([this] { WorkerLoop(); });
}

void JobScheduler::Shutdown() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (std::thread& worker : workers_) {
    if (worker.joinable()) worker.join();
  }
  workers_.clear();
}

std::optional<JobScheduler::Reservation> JobScheduler::TryReserve() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (stopping_ || static_cast<int>(queue_.size()) + reserved_ >= capacity_) return std::nullopt;
  ++reserved_;
  return Reservation(this);
}

void JobScheduler::Release() {
  std::lock_guard<std::mutex> lock(mutex_);
  --reserved_;
}

void JobScheduler::Submit(Reservation reservation, const std::string& id,
                          std::shared_ptr<const Burst> burst) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    reservation.scheduler_ = nullptr;  // the queue entry takes its place
    --reserved_;
    queue_.push_back({id, std::move(burst)});
  }
  wake_.notify_one();
}

void JobScheduler::SubmitRecovered(const std::string& id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back({id, nullptr});
  }
  wake_.notify_one();
}

bool JobScheduler::RemoveQueued(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it =
      std::find_if(queue_.begin(), queue_.end(), [&](const Entry& e) { return e.id == id; });
  if (it == queue_.end()) return false;
  queue_.erase(it);
  return true;
}

bool JobScheduler::IsRunning(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return running_.count(id) > 0;
}

int JobScheduler::Depth() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(queue_.size()) + reserved_;
}

int JobScheduler::Running() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(running_.size());
}

bool JobScheduler::Stalled(std::chrono::steady_clock::duration limit) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!started_ || stopping_ || (queue_.empty() && running_.empty())) return false;
  return std::chrono::steady_clock::now() - progress_ > limit;
}

void JobScheduler::WorkerLoop() {
  for (;;) {
    Entry entry;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      entry = std::move(queue_.front());
      queue_.pop_front();
      running_.insert(entry.id);
      progress_ = std::chrono::steady_clock::now();
    }
    work_(entry.id, std::move(entry.burst));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      running_.erase(entry.id);
      progress_ = std::chrono::steady_clock::now();
    }
  }
}

}  // namespace dfsm::service
