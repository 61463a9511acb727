#include "daemon/service/systemd_notifier.h"

#include <systemd/sd-daemon.h>

#include <iostream>

#include "daemon/log/log.h"

namespace dfsm::service {

SystemdNotifier::SystemdNotifier() {
  uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) interval_ = std::chrono::microseconds(usec);
}

SystemdNotifier::~SystemdNotifier() { StopWatchdog(); }

void SystemdNotifier::Ready(const std::string& status) {
  sd_notify(0, ("READY=1\nSTATUS=" + status).c_str());
}

void SystemdNotifier::Status(const std::string& status) {
  sd_notify(0, ("STATUS=" + status).c_str());
}

void SystemdNotifier::Stopping() { sd_notify(0, "STOPPING=1"); }

void SystemdNotifier::StartWatchdog(std::function<std::string()> problem) {
  if (!watchdog_enabled() || thread_.joinable()) return;
  thread_ = std::thread([this, problem = std::move(problem)] {
    bool was_healthy = true;
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stop_) {
      // The check may take a while (an HTTP probe): not under the lock.
      lock.unlock();
      const std::string found = problem();
      lock.lock();
      const bool ok = found.empty();
      if (ok) sd_notify(0, "WATCHDOG=1");
      if (ok != was_healthy) {
        if (ok) {
          log::Notice("healthy again, watchdog pings resume");
        } else {
          log::Error(found + ", watchdog pings stop");
        }
        was_healthy = ok;
      }
      wake_.wait_for(lock, interval_ / 2, [this] { return stop_; });
    }
  });
}

void SystemdNotifier::StopWatchdog() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

}  // namespace dfsm::service
