// dfsmd's composition root: the only place that knows every part. Assemble()
// builds them from the configuration in dependency order; Serve() binds the
// API, reports readiness to systemd and serves until SIGTERM, SIGINT or SIGHUP
// (a stop, not a reload: the configuration is read once), then
// shuts down in reverse. The route tests and the HTTP fuzz harness assemble
// the same parts (with options below) instead of wiring their own.
//
// Start-up order: state directory lock -> store (recovers unfinished jobs) -> scheduler -> capture
// -> HTTP bind -> serve -> READY=1. Shutdown: STOPPING=1 -> HTTP stop (no new work) -> capture stop
// -> scheduler shutdown (running jobs finish; queued ones stay on disk for the next start) ->
// watchdog stop.
#pragma once

#include <memory>
#include <string>

#include "api/http_server.h"
#include "daemon/capture/capture_service.h"
#include "daemon/service/burst_persister.h"
#include "daemon/service/calibration_keeper.h"
#include "daemon/service/config.h"
#include "daemon/service/job_intake.h"
#include "daemon/service/job_processor.h"
#include "daemon/service/job_scheduler.h"
#include "daemon/service/job_store.h"
#include "daemon/service/metrics.h"
#include "daemon/service/state_dir_lock.h"
#include "dfsmd/capture_camera.h"

namespace dfsm::daemon {

struct AssembleOptions {
  bool camera = true;  // open the configured capture source (false: none)
  // Used instead of opening capture.source when set (tests: a fake device).
  std::shared_ptr<capture::CaptureService> capture;
  bool recover = true;        // re-queue the jobs the last run left unfinished
  bool start_workers = true;  // false: queued jobs stay queued (the route tests)
};

// Declaration order is construction order; the destructor stops what runs
// and destruction goes in reverse, so nothing outlives what it points to.
struct Parts {
  explicit Parts(service::DaemonConfig c) : config(std::move(c)) {}
  ~Parts();

  const service::DaemonConfig config;
  // Taken first and released last: no other dfsmd touches the state directory
  // while these parts exist.
  std::unique_ptr<service::StateDirLock> lock;
  service::Metrics metrics;
  std::unique_ptr<service::JobStore> store;
  // Destroyed after the scheduler: the bursts of queued captures are written
  // before dfsmd exits.
  std::unique_ptr<service::BurstPersister> persister;
  std::unique_ptr<service::CalibrationKeeper> calibration;
  std::unique_ptr<service::JobProcessor> processor;
  std::unique_ptr<service::JobScheduler> scheduler;
  std::shared_ptr<capture::CaptureService> capture;  // null without a camera
  std::unique_ptr<CaptureCamera> camera;
  std::unique_ptr<service::JobIntake> intake;
  std::unique_ptr<api::HttpServer> http;  // routes registered, not bound
};

// Builds every part. Throws service::ConfigError for a state directory or a
// capture source that cannot be used, service::StateDirBusy when another
// dfsmd holds the state directory (before anything in it is read).
std::unique_ptr<Parts> Assemble(const service::DaemonConfig& config,
                                const AssembleOptions& options = {});

// Blocks SIGTERM, SIGINT and SIGHUP in the calling thread and every thread it starts
// afterwards; call before Assemble(). Serve() takes them with sigwait.
void BlockStopSignals();

// Why the systemd watchdog must not be pinged now ("" when all is well):
// capture delivered no frame for capture.stall_timeout_ms, jobs wait or run
// and none started or finished for jobs.stall_timeout_s (a hung job: the
// restart re-queues it), or the API does not answer its own GET /healthz
// through the listening port (a starved or deadlocked server is restarted
// like a stuck camera).
std::string WatchdogVerdict(const Parts& parts);

// Binds, serves until SIGTERM, SIGINT or SIGHUP and shuts down. Returns the exit status.
int Serve(Parts& parts);

}  // namespace dfsm::daemon
