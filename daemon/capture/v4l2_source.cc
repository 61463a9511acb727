#include "daemon/capture/v4l2_source.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/mman.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>

namespace dfsm::capture {

namespace fs = std::filesystem;

namespace {

// Cheapest conversion first; MJPEG last because decoding costs the most CPU.
constexpr uint32_t kPreference[] = {V4L2_PIX_FMT_YUYV,   V4L2_PIX_FMT_UYVY,  V4L2_PIX_FMT_NV12,
                                    V4L2_PIX_FMT_YUV420, V4L2_PIX_FMT_GREY,  V4L2_PIX_FMT_BGR24,
                                    V4L2_PIX_FMT_RGB24,  V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_JPEG};

int64_t MonotonicNowNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

std::string LayoutText(const FrameLayout& layout) {
  return FourccToString(layout.fourcc) + " " + std::to_string(layout.width) + "x" +
         std::to_string(layout.height) + " (bytesperline " + std::to_string(layout.bytesperline) +
         ")";
}

}  // namespace

V4l2Source::Options V4l2Source::Options::FromConfig(const std::string& path,
                                                    const CaptureConfig& config) {
  Options options;
  options.path = path;
  options.width = config.width;
  options.height = config.height;
  options.fps = config.fps;
  options.fourcc = config.pixel_format;
  options.buffers = config.device_buffers;
  options.keep_color = config.keep_color;
  return options;
}

V4l2Source::V4l2Source(Options options, std::unique_ptr<V4l2Device> device)
    : options_(std::move(options)), device_(std::move(device)) {}

V4l2Source::~V4l2Source() { Close(); }

void V4l2Source::Fail(SourceError::Kind kind, const std::string& what, int error) const {
  const std::string where = opened_path_.empty() ? options_.path : opened_path_;
  throw SourceError(
      kind, where + ": " + what + (error != 0 ? std::string(": ") + std::strerror(error) : ""));
}

void V4l2Source::FailIoctl(const char* name, int error) const {
  if (error == ENODEV)
    Fail(SourceError::Kind::kGone, std::string(name) + " failed, device gone", error);
  Fail(SourceError::Kind::kIo, std::string(name) + " failed", error);
}

int V4l2Source::Xioctl(unsigned long request, void* arg, const char* name) {
  const int result = device_->Ioctl(fd_, request, arg);
  if (result < 0) FailIoctl(name, errno);
  return result;
}

std::string V4l2Source::ResolveStablePath() {
  std::error_code ec;
  if (options_.path.rfind(options_.by_id_dir, 0) == 0) return options_.path;
  if (!stable_path_.empty() && fs::exists(stable_path_, ec)) return stable_path_;
  // Remember the stable name of the node we are given, so that a device that
  // comes back under another /dev/videoN after an unplug is found again.
  const fs::path target = fs::canonical(options_.path, ec);
  if (!ec) {
    for (const auto& entry : fs::directory_iterator(options_.by_id_dir, ec)) {
      std::error_code link_ec;
      if (fs::canonical(entry.path(), link_ec) == target && !link_ec) {
        stable_path_ = entry.path().string();
        break;
      }
    }
  }
  return options_.path;
}

void V4l2Source::QueryCapabilities() {
  v4l2_capability cap{};
  Xioctl(VIDIOC_QUERYCAP, &cap, "VIDIOC_QUERYCAP");
  driver_ = reinterpret_cast<const char*>(cap.driver);
  card_ = reinterpret_cast<const char*>(cap.card);
  bus_info_ = reinterpret_cast<const char*>(cap.bus_info);
  const uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE))
    Fail(SourceError::Kind::kConfig,
         "not a single-planar video capture node (driver " + driver_ + ", card \"" + card_ +
             "\"; a UVC camera's second node carries metadata only)",
         0);
  if (!(caps & V4L2_CAP_STREAMING))
    Fail(SourceError::Kind::kConfig, "driver " + driver_ + " does not support streaming I/O", 0);
}

std::vector<uint32_t> V4l2Source::EnumerateFormats() {
  std::vector<uint32_t> formats;
  for (uint32_t index = 0; index < 64; ++index) {
    v4l2_fmtdesc desc{};
    desc.index = index;
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (device_->Ioctl(fd_, VIDIOC_ENUM_FMT, &desc) < 0) {
      if (errno == EINVAL) break;  // the end of the list
      FailIoctl("VIDIOC_ENUM_FMT", errno);
    }
    formats.push_back(desc.pixelformat);
  }
  return formats;
}

void V4l2Source::SetFrameRate() {
  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (device_->Ioctl(fd_, VIDIOC_G_PARM, &parm) < 0) {
    // Drivers without frame-rate control answer ENOTTY/EINVAL; the rate is then measured.
    if (errno != ENOTTY && errno != EINVAL) FailIoctl("VIDIOC_G_PARM", errno);
    fps_ = 0.0;
    return;
  }
  if (options_.fps > 0 && (parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME)) {
    parm.parm.capture.timeperframe.numerator = 1000;
    parm.parm.capture.timeperframe.denominator =
        static_cast<uint32_t>(std::lround(options_.fps * 1000.0));
    if (device_->Ioctl(fd_, VIDIOC_S_PARM, &parm) < 0) {
      if (errno != EINVAL) FailIoctl("VIDIOC_S_PARM", errno);
      // EINVAL: a rate it cannot do; G_PARM below tells what it runs at.
    }
    if (device_->Ioctl(fd_, VIDIOC_G_PARM, &parm) < 0) FailIoctl("VIDIOC_G_PARM", errno);
  }
  const auto& tpf = parm.parm.capture.timeperframe;
  fps_ = tpf.numerator > 0 ? static_cast<double>(tpf.denominator) / tpf.numerator : 0.0;
}

void V4l2Source::NegotiateFormat() {
  const std::vector<uint32_t> offered = EnumerateFormats();
  std::string offered_text;
  for (uint32_t f : offered) offered_text += (offered_text.empty() ? "" : ", ") + FourccToString(f);
  const auto is_offered = [&](uint32_t f) {
    return std::find(offered.begin(), offered.end(), f) != offered.end();
  };
  std::vector<uint32_t> order;
  if (!options_.fourcc.empty()) {
    const uint32_t wanted = FourccFromString(options_.fourcc);
    if (wanted == 0 || !IsSupportedFourcc(wanted))
      Fail(SourceError::Kind::kConfig,
           "pixel format \"" + options_.fourcc +
               "\" is not one dfsm converts (YUYV, UYVY, NV12, YU12, GREY, BGR3, RGB3, MJPG)",
           0);
    if (!is_offered(wanted))
      Fail(SourceError::Kind::kConfig,
           "does not offer " + options_.fourcc + " (offers " + offered_text + ")", 0);
    order.push_back(wanted);
  } else {
    for (uint32_t f : kPreference)
      if (is_offered(f)) order.push_back(f);
    if (order.empty())
      Fail(SourceError::Kind::kConfig,
           "offers none of the formats dfsm converts (offers " + offered_text + ")", 0);
  }

  // The preferred format first; when it cannot reach the asked rate, MJPEG
  // (a UVC camera often reaches high rates only compressed), keeping the faster.
  std::vector<uint32_t> candidates{order.front()};
  if (options_.fourcc.empty() && options_.fps > 0)
    for (uint32_t f : {V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_JPEG})
      if (is_offered(f) && f != order.front()) {
        candidates.push_back(f);
        break;
      }
  uint32_t best = 0;
  double best_fps = -1.0;
  for (size_t i = 0; i < candidates.size(); ++i) {
    ApplyFormat(candidates[i]);
    if (fps_ > best_fps) {
      best = layout_.fourcc == candidates[i] ? candidates[i] : best;
      best_fps = fps_;
    }
    if (options_.fps <= 0 || fps_ <= 0 || fps_ >= 0.9 * options_.fps) return;
  }
  if (best != 0 && best != layout_.fourcc) ApplyFormat(best);
}

void V4l2Source::ApplyFormat(uint32_t fourcc) {
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  Xioctl(VIDIOC_G_FMT, &fmt, "VIDIOC_G_FMT");
  fmt.fmt.pix.pixelformat = fourcc;
  if (options_.width > 0) {
    fmt.fmt.pix.width = static_cast<uint32_t>(options_.width);
    fmt.fmt.pix.height = static_cast<uint32_t>(options_.height);
  }
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  fmt.fmt.pix.bytesperline = 0;  // let the driver choose its padding
  Xioctl(VIDIOC_S_FMT, &fmt, "VIDIOC_S_FMT");
  // The driver's answer is the truth, whatever was asked.
  if (!IsSupportedFourcc(fmt.fmt.pix.pixelformat))
    Fail(SourceError::Kind::kConfig,
         "asked for " + FourccToString(fourcc) + ", the driver chose " +
             FourccToString(fmt.fmt.pix.pixelformat) + ", which dfsm cannot convert",
         0);
  layout_ = {fmt.fmt.pix.pixelformat, static_cast<int>(fmt.fmt.pix.width),
             static_cast<int>(fmt.fmt.pix.height), static_cast<int>(fmt.fmt.pix.bytesperline),
             fmt.fmt.pix.sizeimage};
  if (layout_.width <= 0 || layout_.height <= 0)
    Fail(SourceError::Kind::kIo, "driver answered an empty frame size", 0);
  size_t minimum = 0;
  try {
    minimum = MinimumFrameBytes(layout_);
  } catch (const std::runtime_error& e) {
    Fail(SourceError::Kind::kIo, std::string("driver's layout is unusable: ") + e.what(), 0);
  }
  if (layout_.sizeimage < minimum)
    Fail(SourceError::Kind::kIo,
         "driver's sizeimage " + std::to_string(layout_.sizeimage) + " is too small for " +
             LayoutText(layout_),
         0);
  SetFrameRate();
}

void V4l2Source::QueueBuffer(uint32_t index) {
  v4l2_buffer buffer{};
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  buffer.index = index;
  Xioctl(VIDIOC_QBUF, &buffer, "VIDIOC_QBUF");
}

bool V4l2Source::Requeue(uint32_t index) {
  v4l2_buffer buffer{};
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  buffer.index = index;
  if (device_->Ioctl(fd_, VIDIOC_QBUF, &buffer) == 0) return true;
  const int error = errno;
  // A queue in its error state (vb2_queue_error: a fatal driver error) refuses
  // buffers with EIO until streaming restarts.
  if (error != EIO) FailIoctl("VIDIOC_QBUF", error);
  RestartStreaming();
  return false;
}

void V4l2Source::StartStreaming() {
  v4l2_requestbuffers request{};
  request.count = static_cast<uint32_t>(options_.buffers);
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  Xioctl(VIDIOC_REQBUFS, &request, "VIDIOC_REQBUFS");
  if (request.count < 2)
    Fail(SourceError::Kind::kIo,
         "driver granted " + std::to_string(request.count) + " buffers; streaming needs at least 2",
         0);
  buffers_.assign(request.count, MappedBuffer{});
  for (uint32_t i = 0; i < request.count; ++i) {
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    buffer.index = i;
    Xioctl(VIDIOC_QUERYBUF, &buffer, "VIDIOC_QUERYBUF");
    void* start = device_->Mmap(buffer.length, fd_, static_cast<off_t>(buffer.m.offset));
    if (start == MAP_FAILED)
      Fail(SourceError::Kind::kIo, "mmap of buffer " + std::to_string(i) + " failed", errno);
    buffers_[i] = {start, buffer.length};
  }
  for (uint32_t i = 0; i < request.count; ++i) QueueBuffer(i);
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  Xioctl(VIDIOC_STREAMON, &type, "VIDIOC_STREAMON");
  streaming_ = true;
  have_sequence_ = false;
}

void V4l2Source::StopStreaming() {
  // Runs on error paths too: every step is attempted, the first failure is
  // reported after all of them.
  int first_error = 0;
  const char* failed = nullptr;
  if (streaming_) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (device_->Ioctl(fd_, VIDIOC_STREAMOFF, &type) < 0) {
      first_error = errno;
      failed = "VIDIOC_STREAMOFF";
    }
    streaming_ = false;
  }
  for (const MappedBuffer& buffer : buffers_)
    if (buffer.start != nullptr && device_->Munmap(buffer.start, buffer.length) < 0 && !failed) {
      first_error = errno;
      failed = "munmap";
    }
  if (!buffers_.empty()) {
    buffers_.clear();
    v4l2_requestbuffers request{};
    request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    request.memory = V4L2_MEMORY_MMAP;
    if (device_->Ioctl(fd_, VIDIOC_REQBUFS, &request) < 0 && !failed) {
      first_error = errno;
      failed = "VIDIOC_REQBUFS(0)";
    }
  }
  if (failed != nullptr) FailIoctl(failed, first_error);
}

void V4l2Source::RestartStreaming() {
  StopStreaming();
  StartStreaming();
  ++stream_restarts_;
  discontinuity_pending_ = true;
}

void V4l2Source::Open() {
  Close();
  try {
    opened_path_ = ResolveStablePath();
    fd_ = device_->Open(opened_path_, O_RDWR | O_NONBLOCK);
    if (fd_ < 0) {
      const int error = errno;
      if (error == ENOENT || error == ENODEV || error == ENXIO)
        Fail(SourceError::Kind::kGone, "no such device (unplugged?)", error);
      if (error == EACCES || error == EPERM)
        Fail(SourceError::Kind::kConfig, "cannot open (is the daemon's user in group video?)",
             error);
      if (error == EBUSY) Fail(SourceError::Kind::kIo, "busy: another program uses it", error);
      Fail(SourceError::Kind::kIo, "cannot open", error);
    }
    QueryCapabilities();
    NegotiateFormat();
    v4l2_event_subscription subscription{};
    subscription.type = V4L2_EVENT_SOURCE_CHANGE;
    events_ = device_->Ioctl(fd_, VIDIOC_SUBSCRIBE_EVENT, &subscription) == 0;
    if (!events_ && errno != EINVAL && errno != ENOTTY) FailIoctl("VIDIOC_SUBSCRIBE_EVENT", errno);
    if (layout_.fourcc == V4L2_PIX_FMT_MJPEG || layout_.fourcc == V4L2_PIX_FMT_JPEG)
      mjpeg_ = std::make_unique<MjpegDecoder>();
    StartStreaming();
    dropped_pending_ = 0;
    discontinuity_pending_ = false;
  } catch (...) {
    Close();
    throw;
  }
}

void V4l2Source::Close() {
  if (fd_ >= 0) {
    try {
      StopStreaming();
    } catch (const SourceError&) {
      // Closing a device that is gone fails; closing the descriptor still frees it.
    }
    device_->Close(fd_);
  }
  fd_ = -1;
  streaming_ = false;
  buffers_.clear();
  mjpeg_.reset();
}

void V4l2Source::HandleEvents() {
  for (;;) {
    v4l2_event event{};
    if (device_->Ioctl(fd_, VIDIOC_DQEVENT, &event) < 0) {
      if (errno == ENOENT) return;  // no more events
      FailIoctl("VIDIOC_DQEVENT", errno);
    }
    if (event.type == V4L2_EVENT_SOURCE_CHANGE)
      Fail(SourceError::Kind::kIo,
           "the driver reports a changed source (size or format); renegotiating", 0);
  }
}

void V4l2Source::CheckFormatUnchanged() {
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  Xioctl(VIDIOC_G_FMT, &fmt, "VIDIOC_G_FMT");
  const FrameLayout now{fmt.fmt.pix.pixelformat, static_cast<int>(fmt.fmt.pix.width),
                        static_cast<int>(fmt.fmt.pix.height),
                        static_cast<int>(fmt.fmt.pix.bytesperline), fmt.fmt.pix.sizeimage};
  if (now.fourcc != layout_.fourcc || now.width != layout_.width || now.height != layout_.height ||
      now.bytesperline != layout_.bytesperline)
    Fail(SourceError::Kind::kIo,
         "the driver changed the format from " + LayoutText(layout_) + " to " + LayoutText(now) +
             "; renegotiating",
         0);
}

ReadResult V4l2Source::Read(FrameSlot& slot, std::chrono::milliseconds timeout) {
  if (fd_ < 0 || !streaming_) Fail(SourceError::Kind::kIo, "read while not streaming", 0);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    const int events =
        device_->Poll(fd_, POLLIN | POLLPRI, static_cast<int>(std::max<int64_t>(0, left.count())));
    if (events < 0) {
      if (errno == EINTR) continue;
      Fail(SourceError::Kind::kIo, "poll failed", errno);
    }
    if (events == 0) return ReadResult::kTimeout;
    if (events & POLLPRI) HandleEvents();
    if (events & POLLNVAL) Fail(SourceError::Kind::kIo, "poll: descriptor not open", 0);

    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    if (device_->Ioctl(fd_, VIDIOC_DQBUF, &buffer) < 0) {
      const int error = errno;
      if (error == EAGAIN) {
        // POLLERR without a buffer: the queue is in an error state (or gone).
        if (events & (POLLERR | POLLHUP))
          Fail(SourceError::Kind::kGone, "poll reports an error and no buffer", 0);
        continue;
      }
      if (error == EIO) {
        RestartStreaming();
        continue;
      }
      FailIoctl("VIDIOC_DQBUF", error);
    }
    if (buffer.index >= buffers_.size())
      Fail(SourceError::Kind::kIo,
           "driver dequeued buffer " + std::to_string(buffer.index) + " of " +
               std::to_string(buffers_.size()),
           0);

    if (have_sequence_) {
      if (buffer.sequence > last_sequence_ + 1)
        dropped_pending_ += buffer.sequence - last_sequence_ - 1;
      else if (buffer.sequence <= last_sequence_)
        discontinuity_pending_ = true;  // the driver restarted its count
    }
    have_sequence_ = true;
    last_sequence_ = buffer.sequence;

    if (buffer.flags & V4L2_BUF_FLAG_ERROR) {
      Requeue(buffer.index);
      ++dropped_pending_;
      continue;
    }

    const MappedBuffer& mapped = buffers_[buffer.index];
    const size_t used =
        buffer.bytesused > 0 ? std::min<size_t>(buffer.bytesused, mapped.length) : mapped.length;
    const bool color = options_.keep_color && HasCheapColor(layout_.fourcc);
    bool converted = true;
    std::string conversion_error;
    try {
      ConvertFrame(static_cast<const uint8_t*>(mapped.start), used, layout_, slot.gray,
                   color ? &slot.color : nullptr, mjpeg_.get());
    } catch (const std::exception& e) {
      converted = false;
      conversion_error = e.what();
    }
    // The buffer goes back to the driver before anything else can fail. If
    // that restarted the stream, this frame is still good; the next is not
    // its neighbour (RestartStreaming marks the discontinuity).
    const bool restarted = !Requeue(buffer.index);
    if (!converted) {
      ++dropped_pending_;
      // A short frame usually means the driver switched formats under us.
      if (!restarted) CheckFormatUnchanged();
      continue;
    }
    if (!color) slot.color.release();

    const bool monotonic =
        (buffer.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
    slot.timestamp_ns = monotonic ? static_cast<int64_t>(buffer.timestamp.tv_sec) * 1000000000 +
                                        static_cast<int64_t>(buffer.timestamp.tv_usec) * 1000
                                  : MonotonicNowNs();
    slot.source_sequence = buffer.sequence;
    slot.dropped_before = dropped_pending_;
    slot.discontinuity = discontinuity_pending_ && !restarted;
    dropped_pending_ = 0;
    discontinuity_pending_ = restarted;
    return ReadResult::kFrame;
  }
}

SourceDescription V4l2Source::Describe() const {
  SourceDescription d;
  d.kind = "v4l2";
  d.device = opened_path_.empty() ? options_.path : opened_path_;
  d.driver = driver_;
  d.card = card_;
  d.format = FourccToString(layout_.fourcc);
  d.width = layout_.width;
  d.height = layout_.height;
  d.fps = fps_;
  d.color = options_.keep_color && HasCheapColor(layout_.fourcc);
  d.details = {{"bus_info", bus_info_},          {"bytesperline", layout_.bytesperline},
               {"sizeimage", layout_.sizeimage}, {"buffers", buffers_.size()},
               {"stable_path", stable_path_},    {"stream_restarts", stream_restarts_}};
  return d;
}

}  // namespace dfsm::capture
