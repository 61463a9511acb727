#include "daemon/service/job_intake.h"

#include <fcntl.h>
#include <linux/falloc.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <utility>

namespace dfsm::service {
namespace fs = std::filesystem;
namespace {

constexpr const char* kUploadFile = "upload.tar";

// A file mapped read-only, for as long as this lives.
class MappedFile {
 public:
  explicit MappedFile(const fs::path& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    struct stat info {};
    if (fd < 0 || ::fstat(fd, &info) != 0) {
      const std::string cause = std::strerror(errno);
      if (fd >= 0) ::close(fd);
      throw JobStoreError("cannot read the upload back: " + cause);
    }
    size_ = static_cast<size_t>(info.st_size);
    if (size_ > 0) {
      data_ = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
      if (data_ == MAP_FAILED) {
        data_ = nullptr;
        const std::string cause = std::strerror(errno);
        ::close(fd);
        throw JobStoreError("cannot map the upload: " + cause);
      }
    }
    ::close(fd);
  }
  ~MappedFile() { Close(); }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  std::string_view view() const {
    return data_ ? std::string_view(static_cast<const char*>(data_), size_) : std::string_view();
  }
  void Close() {
    if (data_) ::munmap(data_, size_);
    data_ = nullptr;
  }

 private:
  void* data_ = nullptr;
  size_t size_ = 0;
};

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
  if (!camera_) throw CameraUnavailable("this daemon has no capture source");
  const BurstWhen when = options.when == "next" ? BurstWhen::kNext : BurstWhen::kLast;
  CameraBurst grabbed = camera_->GrabBurst(options.frames, when, timeout);

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

PendingUpload::PendingUpload(JobScheduler::Reservation reservation, fs::path dir)
    : reservation_(std::move(reservation)), dir_(std::move(dir)) {
  const fs::path file = dir_ / kUploadFile;
  fd_ = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd_ < 0) {
    const std::string cause = std::strerror(errno);
    StagingGuard remove{dir_};
    dir_.clear();
    throw JobStoreError("cannot store the upload: " + file.string() + ": " + cause);
  }
}

PendingUpload::PendingUpload(PendingUpload&& other) noexcept
    : reservation_(std::move(other.reservation_)),
      dir_(std::exchange(other.dir_, {})),
      fd_(std::exchange(other.fd_, -1)),
      size_(other.size_) {}

PendingUpload::~PendingUpload() {
  if (fd_ >= 0) ::close(fd_);
  StagingGuard remove{dir_};
}

void PendingUpload::Append(const char* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd_, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      throw JobStoreError("cannot store the upload: " + (dir_ / kUploadFile).string() + ": " +
                          std::strerror(errno));
    }
    data += n;
    size -= static_cast<size_t>(n);
    size_ += n;
  }
}

PendingUpload JobIntake::BeginUpload() {
  JobScheduler::Reservation reservation = Reserve();
  return PendingUpload(std::move(reservation), store_->NewStagingDir());
}

Job JobIntake::FromArchive(std::string_view archive, const JobOptions& options) {
  PendingUpload upload = BeginUpload();
  upload.Append(archive.data(), archive.size());
  return FromUpload(std::move(upload), options);
}

Job JobIntake::FromUpload(PendingUpload upload, const JobOptions& options) {
  ::close(upload.fd_);
  upload.fd_ = -1;
  // The archive is read through a read-only mapping: its pages belong to the
  // page cache, not to dfsmd's heap, and ReadTar's entries point into it.
  const fs::path file = upload.dir_ / kUploadFile;
  MappedFile archive(file);
  std::vector<TarEntry> entries;
  try {
    entries = ReadTar(archive.view(), tar_limits_);
  } catch (const TarError& e) {
    throw BadUpload(e.what());
  }
  const fs::path extracted = upload.dir_ / "upload";
  const int punch = ::open(file.c_str(), O_WRONLY | O_CLOEXEC);
  try {
    fs::create_directories(extracted);
    // ReadTar refused every escaping name: what fails here is the disk. The
    // archive's bytes are released as their files are written (a hole
    // punched in the upload file), so the burst never takes twice its size
    // on disk, which a nearly full state directory would refuse.
    const off_t page = static_cast<off_t>(::sysconf(_SC_PAGESIZE));
    ExtractTar(entries, extracted, [&](const char* end) {
      // Whole pages only, from the start: headers of later entries stay.
      const off_t length = static_cast<off_t>(end - archive.view().data()) / page * page;
      if (punch >= 0 && length > 0)
        ::fallocate(punch, FALLOC_FL_PUNCH_HOLE | FALLOC_FL_KEEP_SIZE, 0, length);
    });
  } catch (const std::exception& e) {
    if (punch >= 0) ::close(punch);
    throw JobStoreError(std::string("cannot store the burst: ") + e.what());
  }
  if (punch >= 0) ::close(punch);
  entries.clear();
  archive.Close();
  fs::remove(file);

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
