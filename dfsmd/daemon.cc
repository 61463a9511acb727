#include "dfsmd/daemon.h"

#include <signal.h>

#include <algorithm>
#include <iostream>
#include <thread>

#include "api/routes.h"
#include "daemon/capture/replay_source.h"
#include "daemon/log/log.h"
#include "daemon/service/systemd_notifier.h"

namespace dfsm::daemon {
namespace {

using service::ConfigError;
using service::Job;
using service::JobStatus;

// The watchdog's API probe waits this long for /healthz (api/http_server.h).
constexpr int kApiProbeTimeoutMs = 2000;

capture::CaptureConfig ToCaptureConfig(const service::CaptureSection& section) {
  capture::CaptureConfig config;
  config.source = section.source;
  config.width = section.width;
  config.height = section.height;
  config.fps = section.fps;
  config.pixel_format = section.pixel_format;
  // One of the key's choices (config_keys.cc), validated before this.
  config.replay_loop = capture::ParseReplayLoop(section.replay_loop);
  config.ring_frames = section.ring_frames;
  config.device_buffers = section.device_buffers;
  config.frame_timeout = std::chrono::milliseconds(section.frame_timeout_ms);
  config.reconnect_backoff = std::chrono::milliseconds(section.reconnect_backoff_ms);
  return config;
}

sigset_t StopSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  // A stop too: dfsmd reads its configuration once, and SIGHUP's default
  // action would end it at once (exit 129) with the running job cut off.
  sigaddset(&signals, SIGHUP);
  return signals;
}

void Recover(Parts& p) {
  for (const Job& job : p.store->Unfinished()) {
    log::Notice("re-queueing job " + job.id + " (was " + JobStatusName(job.status) +
                " when the daemon stopped)");
    Job queued = job;
    queued.status = JobStatus::kQueued;
    queued.stage.clear();
    try {
      p.store->Update(queued);
    } catch (const service::JobStoreError& e) {
      // A full state directory must not keep dfsmd down (systemd would
      // restart it in a loop, and the API that can free space with DELETE
      // would never come up): the job is queued all the same, /readyz
      // reports the disk, and the job's own writes will say what fails.
      log::Error("cannot record job " + job.id + " as queued: " + e.what() +
                 " (starting anyway; see /readyz)");
    }
    p.scheduler->SubmitRecovered(job.id);
  }
  try {
    p.store->EnforceRetention(p.config.retention, service::NowUnixMs());
  } catch (const std::exception& e) {
    log::Error(std::string("retention at start-up: ") + e.what());
  }
}

}  // namespace

Parts::~Parts() {
  if (http) http->Stop();
  if (capture) capture->Stop();
  if (scheduler) scheduler->Shutdown();
}

void BlockStopSignals() {
  const sigset_t signals = StopSignals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
}

std::unique_ptr<Parts> Assemble(const service::DaemonConfig& config,
                                const AssembleOptions& options) {
  auto parts = std::make_unique<Parts>(config);
  Parts& p = *parts;
  const service::DaemonConfig& c = p.config;
  try {
    p.lock = std::make_unique<service::StateDirLock>(c.jobs.state_dir);
  } catch (const std::system_error& e) {
    throw ConfigError(std::string("jobs.state_dir: ") + e.what());
  }
  try {
    p.store = std::make_unique<service::JobStore>(c.jobs.state_dir);
  } catch (const service::JobStoreError& e) {
    throw ConfigError(std::string("jobs.state_dir: ") + e.what());
  }
  p.persister = std::make_unique<service::BurstPersister>(p.store.get());
  p.calibration = std::make_unique<service::CalibrationKeeper>(c.calibration, c.capture.source,
                                                               c.jobs.state_dir);
  BurstLengthOptions burst_length;
  burst_length.target_parallax_px = c.pipeline.auto_parallax_px;
  burst_length.min_parallax_px = c.pipeline.still_parallax_px;
  p.processor = std::make_unique<service::JobProcessor>(
      p.store.get(), &p.metrics, c.retention, p.calibration.get(), p.persister.get(), burst_length);
  p.scheduler = std::make_unique<service::JobScheduler>(
      c.jobs.workers, c.jobs.queue,
      [processor = p.processor.get()](const std::string& id, std::shared_ptr<const Burst> burst) {
        processor->Process(id, std::move(burst));
      });
  if (options.recover) Recover(p);
  if (options.start_workers) p.scheduler->Start();

  if (options.camera) {
    try {
      p.capture = options.capture ? options.capture
                                  : capture::CaptureService::Create(ToCaptureConfig(c.capture));
    } catch (const capture::CaptureConfigError& e) {
      throw ConfigError(e.what());
    }
    p.capture->Start();
    p.camera = std::make_unique<CaptureCamera>(p.capture.get());
  }

  service::TarLimits tar_limits;
  tar_limits.max_total_bytes = c.server.max_body_bytes;
  tar_limits.max_file_bytes = std::min(c.limits.max_upload_file_bytes, c.server.max_body_bytes);
  tar_limits.max_entries = c.limits.max_upload_entries;
  service::BurstLimits burst_limits;
  burst_limits.max_frames = c.limits.max_burst_frames;
  burst_limits.max_frame_pixels = c.limits.max_frame_pixels;
  burst_limits.max_burst_pixels = c.limits.max_burst_pixels;
  p.intake =
      std::make_unique<service::JobIntake>(p.store.get(), p.scheduler.get(), p.camera.get(),
                                           p.persister.get(), &p.metrics, tar_limits, burst_limits);

  p.http = std::make_unique<api::HttpServer>(c.server);
  api::ApiContext context;
  context.config = &p.config;
  context.store = p.store.get();
  context.scheduler = p.scheduler.get();
  context.intake = p.intake.get();
  context.camera = p.camera.get();
  context.metrics = &p.metrics;
  context.calibration = p.calibration.get();
  api::RegisterRoutes(context, p.http.get());
  return parts;
}

std::string WatchdogVerdict(const Parts& p) {
  const int64_t stall_ns = int64_t{p.config.capture.stall_timeout_ms} * 1000000;
  if (stall_ns != 0 && p.camera) {
    const service::CameraHealth health = p.camera->Health();
    if (!health.streaming && (health.last_frame_age_ns < 0 || health.last_frame_age_ns >= stall_ns))
      return "capture is stuck";
  }
  if (p.config.jobs.stall_timeout_s > 0 &&
      p.scheduler->Stalled(std::chrono::seconds(p.config.jobs.stall_timeout_s)))
    return "no job has started or finished for jobs.stall_timeout_s (" +
           std::to_string(p.config.jobs.stall_timeout_s) + " s) while jobs wait or run";
  // The API's own health probe through the listening port: a server whose
  // workers or connections are all taken is restarted too.
  if (!p.http->Probe(std::chrono::milliseconds(kApiProbeTimeoutMs)))
    return "the API does not answer GET /healthz within " + std::to_string(kApiProbeTimeoutMs) +
           " ms";
  return "";
}

int Serve(Parts& p) {
  const service::DaemonConfig& c = p.config;
  int port = 0;
  try {
    port = p.http->Bind();
  } catch (const std::exception& e) {
    log::Error(e.what());
    return 1;
  }
  p.http->Start();

  // READY=1 once the port is bound and capture delivers frames (or has tried
  // for a frame timeout: a camera that is unplugged at boot must not keep the
  // unit "activating" forever; /readyz tells the difference).
  const auto ready_deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(c.capture.frame_timeout_ms);
  while (p.camera && !p.camera->Health().streaming &&
         std::chrono::steady_clock::now() < ready_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const bool streaming = p.camera && p.camera->Health().streaming;
  log::Notice("listening on http://" + c.server.listen + ":" + std::to_string(port) + " (capture " +
              c.capture.source + (streaming ? ", streaming" : ", not streaming yet") + "; state " +
              c.jobs.state_dir.string() + ")");
  service::SystemdNotifier notifier;
  notifier.Ready("serving on " + c.server.listen + ":" + std::to_string(port));
  notifier.StartWatchdog([&p] { return WatchdogVerdict(p); });

  const sigset_t signals = StopSignals();
  int signal_number = 0;
  while (sigwait(&signals, &signal_number) != 0) {
  }
  log::Notice(std::string(signal_number == SIGINT   ? "SIGINT"
                          : signal_number == SIGHUP ? "SIGHUP"
                                                    : "SIGTERM") +
              ", shutting down");
  notifier.Stopping();
  p.http->Stop();
  if (p.capture) p.capture->Stop();
  notifier.Status("finishing the running job");
  p.scheduler->Shutdown();
  notifier.StopWatchdog();
  log::Notice("stopped (" + std::to_string(p.scheduler->Depth()) +
              " queued jobs kept for the next start)");
  return 0;
}

}  // namespace dfsm::daemon
