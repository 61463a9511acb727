#include "daemon/service/burst_persister.h"

#include <system_error>

#include "daemon/log/log.h"

namespace dfsm::service {
namespace {

// Failed writes remembered for jobs that never settle (deleted while queued);
// ids sort by creation time, so the oldest go first.
constexpr size_t kMaxRememberedFailures = 1000;

}  // namespace

BurstPersister::BurstPersister(JobStore* store) : store_(store) {
  thread_ = std::thread([this] { Loop(); });
}

BurstPersister::~BurstPersister() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void BurstPersister::Enqueue(const std::string& id, CameraBurst burst) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back({id, std::move(burst)});
  }
  changed_.notify_all();
}

std::string BurstPersister::Settle(const std::string& id, bool needed) {
  std::unique_lock<std::mutex> lock(mutex_);
  const auto queued = [&] {
    for (auto it = queue_.begin(); it != queue_.end(); ++it) {
      if (it->id == id) return it;
    }
    return queue_.end();
  };
  if (!needed) {
    const auto it = queued();
    if (it != queue_.end()) {
      queue_.erase(it);
      changed_.notify_all();
      return "";
    }
  }
  changed_.wait(lock, [&] { return writing_ != id && queued() == queue_.end(); });
  const auto failed = settled_.find(id);
  if (failed == settled_.end()) return "";
  std::string error = failed->second;
  settled_.erase(failed);
  return error;
}

int BurstPersister::Pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(queue_.size()) + (writing_.empty() ? 0 : 1);
}

void BurstPersister::Loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
    if (queue_.empty()) return;  // stopping, and everything is written
    Entry entry = std::move(queue_.front());
    queue_.pop_front();
    writing_ = entry.id;
    lock.unlock();
    const std::string error = Store(entry);
    entry.burst = {};  // the frames go before the lock is taken again
    lock.lock();
    writing_.clear();
    if (!error.empty()) {
      settled_[entry.id] = error;
      if (settled_.size() > kMaxRememberedFailures) settled_.erase(settled_.begin());
    }
    changed_.notify_all();
  }
}

std::string BurstPersister::Store(const Entry& entry) {
  std::filesystem::path staged;
  try {
    staged = store_->NewStagingDir();
    // One frame after another on this one thread: the job's pipeline, running
    // on the same frames meanwhile, keeps the other cores. (Encoding on every
    // core made a 1080p pipeline 60 % slower on 2 cores; a lower nice value
    // starved the writer whenever anything else ran, and unwritten bursts
    // hold their frames in memory.)
    WriteBurst(staged / "burst", entry.burst.manifest, entry.burst.frames, /*in_parallel=*/false);
    // False when the job was deleted while its burst was written: nothing to keep.
    store_->AttachBurst(entry.id, staged / "burst");
    std::error_code ignored;
    std::filesystem::remove_all(staged, ignored);
    return "";
  } catch (const std::exception& e) {
    std::error_code ignored;
    if (!staged.empty()) std::filesystem::remove_all(staged, ignored);
    const std::string error =
        "cannot store the burst: " + WithoutDirectory(e.what(), store_->state_dir(), "<state_dir>");
    log::Error("job " + entry.id + ": " + error);
    return error;
  }
}

}  // namespace dfsm::service
