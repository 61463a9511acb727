#include "daemon/service/burst_persister.h"

#include "daemon/log/log.h"
#include "daemon/service/staging_guard.h"

namespace dfsm::service {

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

void BurstPersister::Drop(const std::string& id) {
  std::unique_lock<std::mutex> lock(mutex_);
  for (auto it = queue_.begin(); it != queue_.end(); ++it) {
    if (it->id == id) {
      queue_.erase(it);
      changed_.notify_all();
      return;
    }
  }
  changed_.wait(lock, [&] { return writing_ != id; });
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
    Store(entry);
    entry.burst = {};  // the frames go before the lock is taken again
    lock.lock();
    writing_.clear();
    changed_.notify_all();
  }
}

void BurstPersister::Store(const Entry& entry) {
  try {
    // Removed on every path: after AttachBurst has moved the burst out of it,
    // or with the half-written burst of a failure.
    const StagingGuard staged(store_->NewStagingDir());
    // One frame after another on this one thread, stored rather than
    // compressed: the job's pipeline runs on the same frames meanwhile and
    // keeps the other cores. (Compressed, the writer took ~0.7 s of a core per
    // 1080p burst and made the pipeline 23 % slower on 2 cores; encoding on
    // every core, 60 %. A lower nice value starved the writer whenever
    // anything else ran, and unwritten bursts hold their frames in memory.)
    WriteBurstOptions options;
    options.in_parallel = false;
    options.compression = PngCompression::kStored;
    WriteBurst(staged.dir() / "burst", entry.burst.manifest, entry.burst.frames, options);
    // False when the job was deleted while its burst was written: nothing to keep.
    store_->AttachBurst(entry.id, staged.dir() / "burst");
  } catch (const std::exception& e) {
    log::Error("job " + entry.id + ": cannot store the burst: " +
               WithoutDirectory(e.what(), store_->state_dir(), "<state_dir>"));
  }
}

}  // namespace dfsm::service
