#include "daemon/capture/libcamera_source.h"

#include <libcamera/libcamera.h>
#include <libcamera/version.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>

namespace dfsm::capture {

namespace {

using namespace std::chrono;

// libcamera formats dfsm converts, cheapest first, with their V4L2 twins.
struct FormatChoice {
  libcamera::PixelFormat format;
  uint32_t fourcc;
};
const std::vector<FormatChoice>& Choices() {
  static const std::vector<FormatChoice> choices = {
      {libcamera::formats::YUYV, V4L2_PIX_FMT_YUYV},
      {libcamera::formats::UYVY, V4L2_PIX_FMT_UYVY},
      {libcamera::formats::NV12, V4L2_PIX_FMT_NV12},
      {libcamera::formats::YUV420, V4L2_PIX_FMT_YUV420},
      {libcamera::formats::R8, V4L2_PIX_FMT_GREY},
      // libcamera names packed RGB after DRM: RGB888 is B, G, R in memory.
      {libcamera::formats::RGB888, V4L2_PIX_FMT_BGR24},
      {libcamera::formats::BGR888, V4L2_PIX_FMT_RGB24},
      {libcamera::formats::MJPEG, V4L2_PIX_FMT_MJPEG},
  };
  return choices;
}

uint32_t FourccOf(const libcamera::PixelFormat& format) {
  for (const FormatChoice& choice : Choices())
    if (choice.format == format) return choice.fourcc;
  return 0;
}

}  // namespace

LibcameraSource::LibcameraSource(std::string camera_id, const CaptureConfig& config)
    : camera_id_(std::move(camera_id)), config_(config) {}

LibcameraSource::~LibcameraSource() { Close(); }

void LibcameraSource::Fail(SourceError::Kind kind, const std::string& what) const {
  throw SourceError(
      kind,
      "libcamera:" + (camera_id_.empty() ? std::string("<first>") : camera_id_) + ": " + what);
}

void LibcameraSource::Open() {
  Close();
  try {
    manager_ = std::make_unique<libcamera::CameraManager>();
    if (const int error = manager_->start(); error < 0)
      Fail(SourceError::Kind::kIo, std::string("camera manager: ") + std::strerror(-error));
    const auto cameras = manager_->cameras();
    std::string ids;
    for (const auto& camera : cameras) ids += (ids.empty() ? "" : ", ") + camera->id();
    camera_ = camera_id_.empty() ? (cameras.empty() ? nullptr : cameras.front())
                                 : manager_->get(camera_id_);
    if (!camera_)
      Fail(SourceError::Kind::kGone,
           cameras.empty() ? "no cameras (libcamera " + manager_->version() +
                                 " lists none; without udevd it needs /run/udev/data entries)"
                           : "no such camera (cameras: " + ids + ")");
    if (const int error = camera_->acquire(); error < 0)
      Fail(SourceError::Kind::kIo,
           std::string("cannot acquire: ") + std::strerror(-error) + " (another program uses it)");
    acquired_ = true;

#if LIBCAMERA_VERSION_MAJOR == 0 && LIBCAMERA_VERSION_MINOR < 1
    const libcamera::StreamRoles roles{libcamera::StreamRole::VideoRecording};
#else
    // Later releases take a Span and dropped the StreamRoles vector type.
    const std::vector<libcamera::StreamRole> roles{libcamera::StreamRole::VideoRecording};
#endif
    std::unique_ptr<libcamera::CameraConfiguration> configuration =
        camera_->generateConfiguration(roles);
    if (!configuration || configuration->empty())
      Fail(SourceError::Kind::kConfig, "the camera offers no video stream");
    libcamera::StreamConfiguration& stream_config = configuration->at(0);
    // The cheapest format the camera has (or the one asked for).
    const auto offered = stream_config.formats().pixelformats();
    for (const FormatChoice& choice : Choices()) {
      const bool wanted = config_.pixel_format.empty() ||
                          FourccToString(choice.fourcc) == config_.pixel_format ||
                          choice.format.toString() == config_.pixel_format;
      if (wanted && std::find(offered.begin(), offered.end(), choice.format) != offered.end()) {
        stream_config.pixelFormat = choice.format;
        break;
      }
    }
    if (config_.width > 0)
      stream_config.size = {static_cast<unsigned int>(config_.width),
                            static_cast<unsigned int>(config_.height)};
    stream_config.bufferCount =
        std::max(stream_config.bufferCount, static_cast<unsigned int>(config_.device_buffers));
    if (configuration->validate() == libcamera::CameraConfiguration::Invalid)
      Fail(SourceError::Kind::kConfig,
           "the camera rejects the configuration " + stream_config.toString());
    // validate() adjusted what it had to: from here on its answer is used.
    layout_ = {FourccOf(stream_config.pixelFormat), static_cast<int>(stream_config.size.width),
               static_cast<int>(stream_config.size.height), static_cast<int>(stream_config.stride),
               stream_config.frameSize};
    format_name_ = stream_config.pixelFormat.toString();
    if (layout_.fourcc == 0)
      Fail(SourceError::Kind::kConfig,
           "the camera delivers " + format_name_ + ", which dfsm cannot convert");
    if (layout_.bytesperline == 0 && layout_.fourcc != V4L2_PIX_FMT_MJPEG)
      layout_.bytesperline =
          layout_.fourcc == V4L2_PIX_FMT_YUYV || layout_.fourcc == V4L2_PIX_FMT_UYVY
              ? 2 * layout_.width
              : layout_.width;
    if (const int error = camera_->configure(configuration.get()); error < 0)
      Fail(SourceError::Kind::kIo, std::string("configure failed: ") + std::strerror(-error));
    stream_ = stream_config.stream();

    allocator_ = std::make_unique<libcamera::FrameBufferAllocator>(camera_);
    if (allocator_->allocate(stream_) < 0)
      Fail(SourceError::Kind::kIo, "cannot allocate frame buffers");
    const auto& buffers = allocator_->buffers(stream_);
    if (buffers.size() < 4)
      Fail(SourceError::Kind::kIo, "only " + std::to_string(buffers.size()) +
                                       " frame buffers; dfsm keeps at least 4 requests in flight");
    for (const auto& buffer : buffers) {
      std::unique_ptr<libcamera::Request> request = camera_->createRequest(requests_.size());
      if (!request) Fail(SourceError::Kind::kIo, "cannot create a request");
      if (request->addBuffer(stream_, buffer.get()) < 0)
        Fail(SourceError::Kind::kIo, "cannot add a buffer to a request");
      // Map the dmabuf once; plane 0 lies at its offset in it.
      const libcamera::FrameBuffer::Plane& plane = buffer->planes()[0];
      size_t length = 0;
      for (const auto& p : buffer->planes())
        if (p.fd.get() == plane.fd.get()) length = std::max<size_t>(length, p.offset + p.length);
      void* address = mmap(nullptr, length, PROT_READ, MAP_SHARED, plane.fd.get(), 0);
      if (address == MAP_FAILED)
        Fail(SourceError::Kind::kIo,
             std::string("cannot map a frame buffer: ") + std::strerror(errno));
      mappings_.push_back({address, length});
      plane_offsets_.push_back(plane.offset);
      requests_.push_back(std::move(request));
    }
    if (layout_.fourcc == V4L2_PIX_FMT_MJPEG) mjpeg_ = std::make_unique<MjpegDecoder>();

    camera_->requestCompleted.connect(this, &LibcameraSource::OnRequestCompleted);
    camera_->disconnected.connect(this, &LibcameraSource::OnDisconnected);
    libcamera::ControlList start_controls(camera_->controls());
    if (config_.fps > 0 && camera_->controls().count(&libcamera::controls::FrameDurationLimits)) {
      const int64_t frame_us = std::llround(1e6 / config_.fps);
      const std::array<int64_t, 2> limits{frame_us, frame_us};
      start_controls.set(libcamera::controls::FrameDurationLimits,
                         libcamera::Span<const int64_t, 2>(limits));
      fps_ = config_.fps;
    }
    if (const int error = camera_->start(&start_controls); error < 0)
      Fail(SourceError::Kind::kIo, std::string("start failed: ") + std::strerror(-error));
    started_ = true;
    for (auto& request : requests_)
      if (camera_->queueRequest(request.get()) < 0)
        Fail(SourceError::Kind::kIo, "cannot queue a request");
    have_sequence_ = false;
    dropped_pending_ = 0;
  } catch (...) {
    Close();
    throw;
  }
}

void LibcameraSource::Close() {
  if (camera_) {
    if (started_) camera_->stop();  // returns every request, cancelled
    camera_->requestCompleted.disconnect(this, &LibcameraSource::OnRequestCompleted);
    camera_->disconnected.disconnect(this, &LibcameraSource::OnDisconnected);
  }
  started_ = false;
  for (const Mapping& mapping : mappings_) munmap(mapping.address, mapping.length);
  mappings_.clear();
  plane_offsets_.clear();
  requests_.clear();
  if (allocator_ && stream_) allocator_->free(stream_);
  allocator_.reset();
  stream_ = nullptr;
  if (camera_ && acquired_) camera_->release();
  acquired_ = false;
  camera_.reset();
  if (manager_) manager_->stop();
  manager_.reset();
  mjpeg_.reset();
  std::lock_guard<std::mutex> lock(mutex_);
  completed_.clear();
  disconnected_ = false;
}

void LibcameraSource::OnRequestCompleted(libcamera::Request* request) {
  if (request->status() == libcamera::Request::RequestCancelled) return;  // stopping
  {
    std::lock_guard<std::mutex> lock(mutex_);
    completed_.push_back(request);
  }
  completed_cv_.notify_one();
}

void LibcameraSource::OnDisconnected() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    disconnected_ = true;
  }
  completed_cv_.notify_one();
}

const uint8_t* LibcameraSource::PlaneData(const libcamera::Request* request) const {
  const size_t index = static_cast<size_t>(request->cookie());
  return static_cast<const uint8_t*>(mappings_[index].address) + plane_offsets_[index];
}

ReadResult LibcameraSource::Read(FrameSlot& slot, milliseconds timeout) {
  if (!started_) Fail(SourceError::Kind::kIo, "read while not streaming");
  const auto deadline = steady_clock::now() + timeout;
  uint64_t& dropped = dropped_pending_;
  for (;;) {
    libcamera::Request* request = nullptr;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      completed_cv_.wait_until(lock, deadline,
                               [this] { return disconnected_ || !completed_.empty(); });
      if (disconnected_) Fail(SourceError::Kind::kGone, "camera disconnected");
      if (completed_.empty()) return ReadResult::kTimeout;
      request = completed_.front();
      completed_.pop_front();
    }
    libcamera::FrameBuffer* buffer = request->findBuffer(stream_);
    const libcamera::FrameMetadata& metadata = buffer->metadata();
    if (have_sequence_ && metadata.sequence > last_sequence_ + 1)
      dropped += metadata.sequence - last_sequence_ - 1;
    have_sequence_ = true;
    last_sequence_ = metadata.sequence;

    bool ok = metadata.status == libcamera::FrameMetadata::FrameSuccess;
    const bool color = config_.keep_color && HasCheapColor(layout_.fourcc);
    if (ok) {
      try {
        size_t used = 0;
        for (const auto& plane : metadata.planes()) used += plane.bytesused;
        ConvertFrame(PlaneData(request), used, layout_, slot.gray, color ? &slot.color : nullptr,
                     mjpeg_.get());
      } catch (const std::exception&) {
        ok = false;
      }
    }
    const auto timestamp = request->metadata().get(libcamera::controls::SensorTimestamp);
    // Back to the camera at once, with the controls a burst asked for.
    request->reuse(libcamera::Request::ReuseBuffers);
    if (hold_ >= 0) {
      const libcamera::ControlInfoMap& info = camera_->controls();
      if (info.count(&libcamera::controls::AeEnable))
        request->controls().set(libcamera::controls::AeEnable, hold_ == 0);
      if (info.count(&libcamera::controls::AwbEnable))
        request->controls().set(libcamera::controls::AwbEnable, hold_ == 0);
      if (hold_ == 1 && info.count(&libcamera::controls::AfMode))
        request->controls().set(libcamera::controls::AfMode,
                                static_cast<int32_t>(libcamera::controls::AfModeManual));
      hold_ = -1;
    }
    if (camera_->queueRequest(request) < 0)
      Fail(SourceError::Kind::kIo, "cannot queue a request again");
    if (!ok) {
      ++dropped;
      continue;
    }
    if (!color) slot.color.release();
    const int64_t sensor_ns = timestamp.value_or(0);
    slot.timestamp_ns = sensor_ns > 0 ? sensor_ns : static_cast<int64_t>(metadata.timestamp);
    slot.source_sequence = metadata.sequence;
    slot.dropped_before = dropped;
    slot.discontinuity = false;
    dropped = 0;
    return ReadResult::kFrame;
  }
}

void LibcameraSource::HoldControls(bool hold) { hold_ = hold ? 1 : 0; }

SourceDescription LibcameraSource::Describe() const {
  SourceDescription d;
  d.kind = "libcamera";
  d.device = camera_ ? camera_->id() : camera_id_;
  d.driver = std::string("libcamera ") + (manager_ ? manager_->version() : "");
  d.format = format_name_;
  d.width = layout_.width;
  d.height = layout_.height;
  d.fps = fps_;
  d.color = config_.keep_color && HasCheapColor(layout_.fourcc);
  d.details = {{"stride", layout_.bytesperline},
               {"frame_size", layout_.sizeimage},
               {"requests", requests_.size()}};
  return d;
}

}  // namespace dfsm::capture
