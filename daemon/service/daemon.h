// dfsmd as a whole: owns the capture service, the job store, the scheduler and
// its workers, the HTTP server and the systemd notifier, starts them in
// dependency order and stops them in reverse.
//
// Start-up order: store (recovers unfinished jobs) -> scheduler -> capture ->
// HTTP bind -> serve -> READY=1. Shutdown: STOPPING=1 -> HTTP stop (no new
// work) -> capture stop -> scheduler shutdown (running jobs finish; queued
// ones stay on disk for the next start) -> watchdog stop.
#pragma once

#include <memory>

#include "daemon/service/config.h"

namespace dfsm::service {

class Daemon {
 public:
  explicit Daemon(DaemonConfig config);
  ~Daemon();

  // Starts everything and serves until SIGTERM or SIGINT, then shuts down.
  // Returns the process exit status. Throws ConfigError (exit 78) for a
  // configuration the capture source rejects.
  int Run();

 private:
  struct Parts;
  DaemonConfig config_;
  std::unique_ptr<Parts> parts_;
};

}  // namespace dfsm::service
