#include "daemon/service/job_intake.h"

#include <filesystem>
#include <system_error>
#include <utility>

#include "daemon/service/staging_guard.h"
#include "daemon/service/tar_extract.h"

namespace dfsm::service {
namespace fs = std::filesystem;
namespace {

nlohmann::json InputSummary(const Burst& burst) {
  return {{"width", burst.width()},
          {"height", burst.height()},
          {"frames", burst.size()},
          {"pixel_format", burst.manifest.pixel_format}};
}

}  // namespace

JobScheduler::Reservation JobIntake::Reserve() {
  std::optional<JobScheduler::Reservation> reservation = scheduler_->TryReserve();
  if (!reservation) {
    metrics_->JobRejected();
    throw QueueFull("the job queue is full (" + std::to_string(scheduler_->capacity()) +
                    " waiting)");
  }
  return std::move(*reservation);
}

Job JobIntake::FromCapture(const JobOptions& options, std::chrono::milliseconds timeout) {
  JobScheduler::Reservation reservation = Reserve();
  if (!camera_ || !persister_) throw CameraUnavailable("this daemon has no capture source");
  // Bursts waiting to be stored hold their frames in memory: as many as the
  // queue holds jobs, no more.
  if (persister_->Pending() >= scheduler_->capacity()) {
    metrics_->JobRejected();
    throw QueueFull("the bursts of " + std::to_string(persister_->Pending()) +
                    " captures are still being stored");
  }
  const BurstWhen when = options.when.value_or(BurstWhen::kLast);
  CameraBurst grabbed = camera_->GrabBurst(options.frames, when, timeout);
  // "frames": "auto" keeps the frames nearest the trigger (burst_length.h):
  // of the last ones, the newest, which is then the reference.
  if (options.auto_frames && when == BurstWhen::kLast && !grabbed.frames.empty())
    grabbed.manifest.reference = static_cast<int>(grabbed.frames.size()) - 1;

  auto burst = std::make_shared<Burst>();
  try {
    grabbed.manifest = CompleteManifest(std::move(grabbed.manifest), grabbed.frames);
  } catch (const BurstError& e) {
    throw CameraUnavailable(std::string("the camera gave no usable burst: ") + e.what());
  }
  burst->manifest = grabbed.manifest;
  burst->gray.resize(grabbed.frames.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(grabbed.frames.size())),
                    [&](const cv::Range& range) {
                      for (int i = range.start; i < range.end; ++i)
                        burst->gray[i] = ToGray8(grabbed.frames[i]);
                    });
  const cv::Mat& reference = grabbed.frames.at(burst->manifest.reference);
  burst->reference_color = reference.channels() == 3 ? reference : burst->gray[burst->reference()];

  Job job = store_->Create("capture", options, {}, InputSummary(*burst));
  persister_->Enqueue(job.id, std::move(grabbed));
  scheduler_->Submit(std::move(reservation), job.id, std::move(burst));
  return job;
}

PendingUpload::PendingUpload(JobScheduler::Reservation reservation, fs::path dir,
                             const TarLimits& limits)
    : reservation_(std::move(reservation)), dir_(std::move(dir)) {
  try {
    extraction_ = std::make_unique<StreamingExtraction>(dir_ / "upload", limits);
  } catch (const std::system_error& e) {
    StagingGuard remove(std::exchange(dir_, {}));
    throw JobStoreError(std::string("cannot store the upload: ") + e.what());
  }
}

PendingUpload::PendingUpload(PendingUpload&& other) noexcept
    : reservation_(std::move(other.reservation_)),
      dir_(std::exchange(other.dir_, {})),
      extraction_(std::move(other.extraction_)),
      size_(other.size_) {}

PendingUpload::~PendingUpload() {
  extraction_.reset();  // its thread writes into dir_
  StagingGuard remove(std::move(dir_));
}

void PendingUpload::Append(const char* data, size_t size) {
  try {
    extraction_->Write(data, size);
  } catch (const std::system_error& e) {
    throw JobStoreError(std::string("cannot store the upload: ") + e.what());
  }
  size_ += static_cast<int64_t>(size);
}

PendingUpload JobIntake::BeginUpload() {
  JobScheduler::Reservation reservation = Reserve();
  return PendingUpload(std::move(reservation), store_->NewStagingDir(), tar_limits_);
}

Job JobIntake::FromArchive(std::string_view archive, const JobOptions& options) {
  PendingUpload upload = BeginUpload();
  upload.Append(archive.data(), archive.size());
  return FromUpload(std::move(upload), options);
}

Job JobIntake::FromUpload(PendingUpload upload, const JobOptions& options) {
  try {
    upload.extraction_->Finish();
  } catch (const TarError& e) {
    throw BadUpload(e.what());
  } catch (const std::exception& e) {
    throw JobStoreError(std::string("cannot store the burst: ") + e.what());
  }
  const fs::path extracted = upload.dir_ / "upload";

  const std::optional<fs::path> burst_root = BurstRootOf(extracted);
  if (!burst_root)
    throw BadUpload(
        "the archive has no manifest.json at its top level or in a single top-level directory");
  const fs::path root = *burst_root;
  BurstManifest manifest;
  try {
    manifest = ReadBurstManifest(root);
    // Refuse before anything decodes: a tiny PNG can claim an enormous frame.
    CheckUploadedBurst(root, manifest, options.frames, burst_limits_);
  } catch (const BurstError& e) {
    throw BadUpload(WithoutDirectory(e.what(), extracted, "the archive"));
  }
  const int frames = options.frames > 0
                         ? std::min<int>(options.frames, static_cast<int>(manifest.frames.size()))
                         : static_cast<int>(manifest.frames.size());
  const nlohmann::json input = {{"width", manifest.width},
                                {"height", manifest.height},
                                {"frames", frames},
                                {"pixel_format", manifest.pixel_format}};
  Job job = store_->Create("upload", options, root, input);
  // The burst moved into the job; the staging directory goes with `upload`.
  scheduler_->Submit(std::move(upload.reservation_), job.id, nullptr);
  return job;
}

}  // namespace dfsm::service
