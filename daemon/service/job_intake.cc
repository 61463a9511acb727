#include "daemon/service/job_intake.h"

#include <filesystem>

namespace dfsm::service {
namespace fs = std::filesystem;
namespace {

nlohmann::json InputSummary(const Burst& burst) {
  return {{"width", burst.width()},
          {"height", burst.height()},
          {"frames", burst.size()},
          {"pixel_format", burst.manifest.pixel_format}};
}

// RAII removal of a staging directory that did not become part of a job.
struct StagingGuard {
  fs::path dir;
  ~StagingGuard() {
    std::error_code error;
    if (!dir.empty()) fs::remove_all(dir, error);
  }
};

// `message` with the staging directory taken out of every path in it: the
// client named its files relative to the archive, and the daemon's state
// directory is none of its business.
std::string ArchiveRelative(std::string message, const fs::path& extracted) {
  const std::string prefix = extracted.string() + "/";
  for (size_t at = message.find(prefix); at != std::string::npos; at = message.find(prefix, at))
    message.erase(at, prefix.size());
  const std::string bare = extracted.string();
  for (size_t at = message.find(bare); at != std::string::npos; at = message.find(bare, at))
    message.replace(at, bare.size(), "the archive");
  return message;
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
  if (!capture_) throw capture::CaptureUnavailable("this daemon has no capture source");
  const capture::BurstWhen when =
      options.when == "next" ? capture::BurstWhen::kNext : capture::BurstWhen::kLast;
  capture::CaptureService::Burst grabbed = capture_->GrabBurst(options.frames, when, timeout);

  StagingGuard staging{store_->NewStagingDir()};
  const fs::path burst_dir = staging.dir / "burst";
  try {
    WriteBurst(burst_dir, grabbed.manifest, grabbed.frames);
  } catch (const BurstError& e) {
    throw JobStoreError(std::string("cannot store the burst: ") + e.what());
  }

  auto burst = std::make_shared<Burst>();
  burst->manifest = ReadBurstManifest(burst_dir);
  for (const cv::Mat& frame : grabbed.frames) burst->gray.push_back(ToGray8(frame));
  const cv::Mat& reference = grabbed.frames.at(burst->manifest.reference);
  burst->reference_color = reference.channels() == 3 ? reference : burst->gray[burst->reference()];

  Job job = store_->Create("capture", options, burst_dir, InputSummary(*burst));
  scheduler_->Submit(std::move(reservation), job.id, std::move(burst));
  return job;
}

Job JobIntake::FromArchive(std::string_view archive, const JobOptions& options) {
  JobScheduler::Reservation reservation = Reserve();
  std::vector<TarEntry> entries;
  try {
    entries = ReadTar(archive, tar_limits_);
  } catch (const TarError& e) {
    throw BadUpload(e.what());
  }
  StagingGuard staging{store_->NewStagingDir()};
  const fs::path extracted = staging.dir / "upload";
  try {
    fs::create_directories(extracted);
    // ReadTar refused every escaping name: what fails here is the disk.
    ExtractTar(entries, extracted);
  } catch (const std::exception& e) {
    throw JobStoreError(std::string("cannot store the burst: ") + e.what());
  }

  // The burst is the archive's top level, or its single top-level directory.
  fs::path root = extracted;
  if (!fs::exists(root / "manifest.json")) {
    std::vector<fs::path> children;
    for (const auto& child : fs::directory_iterator(extracted)) children.push_back(child.path());
    if (children.size() == 1 && fs::is_directory(children[0]) &&
        fs::exists(children[0] / "manifest.json")) {
      root = children[0];
    } else {
      throw BadUpload(
          "the archive has no manifest.json at its top level or in a single top-level directory");
    }
  }
  auto burst = std::make_shared<Burst>();
  try {
    // Refuse before decoding: a tiny PNG can claim an enormous frame.
    CheckUploadedBurst(root, ReadBurstManifest(root), options.frames, burst_limits_);
    ReadBurstOptions read;
    read.max_frames = options.frames;
    *burst = ReadBurst(root, read);
  } catch (const BurstError& e) {
    throw BadUpload(ArchiveRelative(e.what(), extracted));
  }
  Job job = store_->Create("upload", options, root, InputSummary(*burst));
  scheduler_->Submit(std::move(reservation), job.id, std::move(burst));
  return job;
}

}  // namespace dfsm::service
