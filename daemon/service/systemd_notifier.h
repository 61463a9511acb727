// The daemon's side of systemd's Type=notify protocol: READY=1 once the port
// is bound and capture runs, STOPPING=1 on shutdown, and WATCHDOG=1 pings from
// a thread of their own while the daemon is healthy. Without $NOTIFY_SOCKET
// (not started by systemd) every call is a no-op.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace dfsm::service {

class SystemdNotifier {
 public:
  // Decides at construction whether systemd asked for a watchdog
  // (sd_watchdog_enabled: WatchdogSec= in the unit).
  SystemdNotifier();
  ~SystemdNotifier();  // StopWatchdog()
  SystemdNotifier(const SystemdNotifier&) = delete;
  SystemdNotifier& operator=(const SystemdNotifier&) = delete;

  void Ready(const std::string& status);
  void Status(const std::string& status);
  void Stopping();

  // Pings every half watchdog period while `problem()` finds none (returns
  // ""). A stuck capture or a starved HTTP server is a problem: the pings
  // stop, the problem is logged, and systemd restarts the daemon.
  void StartWatchdog(std::function<std::string()> problem);
  void StopWatchdog();

  bool watchdog_enabled() const { return interval_.count() > 0; }
  std::chrono::microseconds watchdog_interval() const { return interval_; }

 private:
  std::chrono::microseconds interval_{0};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace dfsm::service
