#include "daemon/service/daemon.h"

#include <signal.h>

#include <algorithm>
#include <iostream>

#include "api/http_server.h"
#include "api/routes.h"
#include "daemon/capture/capture_service.h"
#include "daemon/service/calibration_keeper.h"
#include "daemon/service/job_intake.h"
#include "daemon/service/job_processor.h"
#include "daemon/service/job_scheduler.h"
#include "daemon/service/job_store.h"
#include "daemon/service/metrics.h"
#include "daemon/service/systemd_notifier.h"

namespace dfsm::service {
namespace {

capture::CaptureConfig ToCaptureConfig(const CaptureSection& section) {
  capture::CaptureConfig config;
  config.source = section.source;
  config.width = section.width;
  config.height = section.height;
  config.fps = section.fps;
  config.pixel_format = section.pixel_format;
  config.ring_frames = section.ring_frames;
  config.device_buffers = section.device_buffers;
  config.frame_timeout = std::chrono::milliseconds(section.frame_timeout_ms);
  config.reconnect_backoff = std::chrono::milliseconds(section.reconnect_backoff_ms);
  return config;
}

// The watchdog's API probe waits this long for /healthz (api/http_server.h).
constexpr int kApiProbeTimeoutMs = 2000;

int64_t MonotonicNs() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<int64_t>(now.tv_sec) * 1000000000LL + now.tv_nsec;
}

}  // namespace

// Declaration order is construction order; destruction runs in reverse, so
// nothing outlives what it points to.
struct Daemon::Parts {
  Metrics metrics;
  std::unique_ptr<JobStore> store;
  std::unique_ptr<CalibrationKeeper> calibration;
  std::unique_ptr<JobProcessor> processor;
  std::unique_ptr<JobScheduler> scheduler;
  std::unique_ptr<capture::CaptureService> capture;
  std::unique_ptr<JobIntake> intake;
  std::unique_ptr<api::HttpServer> http;
  SystemdNotifier notifier;
};

Daemon::Daemon(DaemonConfig config) : config_(std::move(config)) {}

Daemon::~Daemon() = default;

int Daemon::Run() {
  // Block the stop signals in every thread (threads inherit the mask) and take
  // them synchronously with sigwait below: no async-signal-safety concerns.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  parts_ = std::make_unique<Parts>();
  Parts& p = *parts_;
  try {
    p.store = std::make_unique<JobStore>(config_.jobs.state_dir);
  } catch (const JobStoreError& e) {
    throw ConfigError(std::string("jobs.state_dir: ") + e.what());
  }
  p.calibration = std::make_unique<CalibrationKeeper>(config_.calibration, config_.jobs.state_dir);
  p.processor = std::make_unique<JobProcessor>(p.store.get(), &p.metrics, config_.retention,
                                               p.calibration.get());
  p.scheduler = std::make_unique<JobScheduler>(
      config_.jobs.workers, config_.jobs.queue,
      [processor = p.processor.get()](const std::string& id, std::shared_ptr<const Burst> burst) {
        processor->Process(id, std::move(burst));
      });
  const std::vector<Job> unfinished = p.store->Unfinished();
  for (const Job& job : unfinished) {
    std::cerr << "dfsmd: re-queueing job " << job.id << " (was " << JobStatusName(job.status)
              << " when the daemon stopped)\n";
    Job queued = job;
    queued.status = JobStatus::kQueued;
    queued.stage.clear();
    try {
      p.store->Update(queued);
    } catch (const JobStoreError& e) {
      // A full state directory must not keep dfsmd down (systemd would
      // restart it in a loop, and the API that can free space with DELETE
      // would never come up): the job is queued all the same, /readyz
      // reports the disk, and the job's own writes will say what fails.
      std::cerr << "dfsmd: cannot record job " << job.id << " as queued: " << e.what()
                << " (starting anyway; see /readyz)\n";
    }
    p.scheduler->SubmitRecovered(job.id);
  }
  try {
    p.store->EnforceRetention(config_.retention, NowUnixMs());
  } catch (const std::exception& e) {
    std::cerr << "dfsmd: retention at start-up: " << e.what() << "\n";
  }
  p.scheduler->Start();

  try {
    p.capture = capture::CaptureService::Create(ToCaptureConfig(config_.capture));
  } catch (const capture::CaptureConfigError& e) {
    throw ConfigError(e.what());
  }
  p.capture->Start();

  TarLimits tar_limits;
  tar_limits.max_total_bytes = config_.server.max_body_bytes;
  tar_limits.max_file_bytes =
      std::min(config_.limits.max_upload_file_bytes, config_.server.max_body_bytes);
  tar_limits.max_entries = config_.limits.max_upload_entries;
  BurstLimits burst_limits;
  burst_limits.max_frames = config_.limits.max_burst_frames;
  burst_limits.max_frame_pixels = config_.limits.max_frame_pixels;
  burst_limits.max_burst_pixels = config_.limits.max_burst_pixels;
  p.intake = std::make_unique<JobIntake>(p.store.get(), p.scheduler.get(), p.capture.get(),
                                         &p.metrics, tar_limits, burst_limits);

  p.http = std::make_unique<api::HttpServer>(config_.server);
  api::ApiContext context;
  context.config = &config_;
  context.store = p.store.get();
  context.scheduler = p.scheduler.get();
  context.intake = p.intake.get();
  context.capture = p.capture.get();
  context.metrics = &p.metrics;
  context.calibration = p.calibration.get();
  api::RegisterRoutes(context, p.http.get());
  int port = 0;
  try {
    port = p.http->Bind();
  } catch (const std::exception& e) {
    std::cerr << "dfsmd: " << e.what() << "\n";
    p.capture->Stop();
    return 1;
  }
  p.http->Start();

  // READY=1 once the port is bound and capture delivers frames (or has tried
  // for a frame timeout: a camera that is unplugged at boot must not keep the
  // unit "activating" forever; /readyz tells the difference).
  const auto ready_deadline = std::chrono::steady_clock::now() +
                              std::chrono::milliseconds(config_.capture.frame_timeout_ms);
  while (!p.capture->Status().streaming && std::chrono::steady_clock::now() < ready_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const capture::CaptureStatus status = p.capture->Status();
  std::cerr << "dfsmd: listening on http://" << config_.server.listen << ":" << port << " (capture "
            << config_.capture.source << (status.streaming ? ", streaming" : ", not streaming yet")
            << "; state " << config_.jobs.state_dir.string() << ")" << std::endl;
  p.notifier.Ready("serving on " + config_.server.listen + ":" + std::to_string(port));
  const int64_t stall_ns = int64_t{config_.capture.stall_timeout_ms} * 1000000;
  capture::CaptureService* capture = p.capture.get();
  api::HttpServer* http = p.http.get();
  p.notifier.StartWatchdog([capture, http, stall_ns]() -> std::string {
    if (stall_ns != 0) {
      const capture::CaptureStatus s = capture->Status();
      if (!s.streaming &&
          (s.last_frame_monotonic_ns == 0 || MonotonicNs() - s.last_frame_monotonic_ns >= stall_ns))
        return "capture is stuck";
    }
    // The API's own health probe through the listening port: a server whose
    // workers or connections are all taken is restarted too.
    if (!http->Probe(std::chrono::milliseconds(kApiProbeTimeoutMs)))
      return "the API does not answer GET /healthz within " + std::to_string(kApiProbeTimeoutMs) +
             " ms";
    return "";
  });

  int signal_number = 0;
  while (sigwait(&stop_signals, &signal_number) != 0) {
  }
  std::cerr << "dfsmd: " << (signal_number == SIGINT ? "SIGINT" : "SIGTERM") << ", shutting down"
            << std::endl;
  p.notifier.Stopping();
  p.http->Stop();
  p.capture->Stop();
  p.notifier.Status("finishing the running job");
  p.scheduler->Shutdown();
  p.notifier.StopWatchdog();
  std::cerr << "dfsmd: stopped (" << p.scheduler->Depth() << " queued jobs kept for the next start)"
            << std::endl;
  return 0;
}

}  // namespace dfsm::service
