// Turns a request into a stored, queued job: a burst taken from the capture
// ring or an uploaded tar of a dfsm-burst/1 directory. An upload is on disk
// before its job exists. A capture's job is recorded at once and runs on the
// frames in memory, while BurstPersister stores them beside it: the answer
// does not wait for ten PNG encodings.
#pragma once

#include <chrono>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>

#include "daemon/service/burst_limits.h"
#include "daemon/service/burst_persister.h"
#include "daemon/service/camera_port.h"
#include "daemon/service/job_scheduler.h"
#include "daemon/service/job_store.h"
#include "daemon/service/metrics.h"
#include "daemon/service/streaming_extraction.h"  // and TarLimits

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

// An upload being received: it holds its place in the queue (taken before the
// first body byte is read, so a full queue costs the client nothing) and
// extracts the tar into the state directory's staging area as it arrives: no
// upload is ever held whole. Move-only; dropping it frees both.
class PendingUpload {
 public:
  PendingUpload(PendingUpload&& other) noexcept;
  PendingUpload& operator=(PendingUpload&&) = delete;
  ~PendingUpload();

  // Passes body bytes to the extraction. Throws JobStoreError.
  void Append(const char* data, size_t size);
  int64_t size() const { return size_; }

 private:
  friend class JobIntake;
  PendingUpload(JobScheduler::Reservation reservation, std::filesystem::path dir,
                const TarLimits& limits);

  JobScheduler::Reservation reservation_;
  std::filesystem::path dir_;                        // staging; removed unless it became a job
  std::unique_ptr<StreamingExtraction> extraction_;  // into dir_/upload
  int64_t size_ = 0;
};

class JobIntake {
 public:
  // `camera` may be null (then FromCapture throws CameraUnavailable);
  // `persister` stores the captured bursts.
  JobIntake(JobStore* store, JobScheduler* scheduler, CameraPort* camera, BurstPersister* persister,
            Metrics* metrics, TarLimits tar_limits, BurstLimits burst_limits = {})
      : store_(store),
        scheduler_(scheduler),
        camera_(camera),
        persister_(persister),
        metrics_(metrics),
        tar_limits_(tar_limits),
        burst_limits_(burst_limits) {}

  // Throws QueueFull, CameraUnavailable, JobStoreError.
  Job FromCapture(const JobOptions& options, std::chrono::milliseconds timeout);
  // Starts an upload: reserves a place in the queue and a staging file.
  // Throws QueueFull, JobStoreError.
  PendingUpload BeginUpload();
  // Turns a received upload (a tar of a dfsm-burst/1 directory) into a queued
  // job. The frames' headers are checked against the burst limits here; the
  // frames are decoded by the job when it runs, so a queued job holds no
  // pixels in memory. options.frames == 0 keeps every frame of the upload.
  // Throws BadUpload, JobStoreError.
  Job FromUpload(PendingUpload upload, const JobOptions& options);
  // BeginUpload, Append and FromUpload at once.
  Job FromArchive(std::string_view archive, const JobOptions& options);

 private:
  JobScheduler::Reservation Reserve();

  JobStore* store_;
  JobScheduler* scheduler_;
  CameraPort* camera_;
  BurstPersister* persister_;
  Metrics* metrics_;
  const TarLimits tar_limits_;
  const BurstLimits burst_limits_;
};

}  // namespace dfsm::service
