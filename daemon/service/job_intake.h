// Turns a request into a stored, queued job: a burst taken from the capture
// ring or an uploaded tar of a dfsm-burst/1 directory. The burst is written
// to disk before the job exists, so an accepted job survives a crash.
#pragma once

#include <chrono>
#include <stdexcept>
#include <string>
#include <string_view>

#include "daemon/capture/capture_service.h"
#include "daemon/service/burst_limits.h"
#include "daemon/service/job_scheduler.h"
#include "daemon/service/job_store.h"
#include "daemon/service/metrics.h"
#include "daemon/service/ustar.h"

namespace dfsm::service {

// The queue is full: come back later.
class QueueFull : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// An upload that is not a usable burst; the message names the problem.
class BadUpload : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class JobIntake {
 public:
  // `capture` may be null (then FromCapture throws capture::CaptureUnavailable).
  JobIntake(JobStore* store, JobScheduler* scheduler, capture::CaptureService* capture,
            Metrics* metrics, TarLimits tar_limits, BurstLimits burst_limits = {})
      : store_(store),
        scheduler_(scheduler),
        capture_(capture),
        metrics_(metrics),
        tar_limits_(tar_limits),
        burst_limits_(burst_limits) {}

  // Throws QueueFull, capture::CaptureUnavailable, JobStoreError.
  Job FromCapture(const JobOptions& options, std::chrono::milliseconds timeout);
  // options.frames == 0 keeps every frame of the upload. Throws QueueFull,
  // BadUpload, JobStoreError.
  Job FromArchive(std::string_view archive, const JobOptions& options);

 private:
  JobScheduler::Reservation Reserve();

  JobStore* store_;
  JobScheduler* scheduler_;
  capture::CaptureService* capture_;
  Metrics* metrics_;
  const TarLimits tar_limits_;
  const BurstLimits burst_limits_;
};

}  // namespace dfsm::service
