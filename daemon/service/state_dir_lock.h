// One dfsmd per state directory: an exclusive flock(2) on
// <state_dir>/dfsmd.lock, taken before anything in the directory is read.
// A second daemon started on the same directory (by mistake, or by a unit
// restarting while the old process lingers) would otherwise re-queue the
// first one's running job and process it too. The kernel drops the lock when
// the holder exits, kill -9 included, so a stale lock never blocks a start.
#pragma once

#include <filesystem>
#include <stdexcept>

namespace dfsm::service {

class StateDirBusy : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class StateDirLock {
 public:
  // Creates the directory when missing. Throws StateDirBusy naming the holder's
  // pid when another process holds the lock, std::system_error when the lock
  // file cannot be opened or locked.
  explicit StateDirLock(const std::filesystem::path& state_dir);
  ~StateDirLock();
  StateDirLock(const StateDirLock&) = delete;
  StateDirLock& operator=(const StateDirLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace dfsm::service
