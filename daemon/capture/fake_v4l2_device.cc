#include "daemon/capture/fake_v4l2_device.h"

#include <linux/videodev2.h>
#include <poll.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace dfsm::capture {

FakeV4l2Driver::FakeV4l2Driver()
    : formats{V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_NV12, V4L2_PIX_FMT_GREY} {}

namespace {

constexpr int kFd = 42;

class FakeV4l2Device : public V4l2Device {
 public:
  explicit FakeV4l2Device(std::shared_ptr<FakeV4l2Driver> driver) : d_(std::move(driver)) {
    SetFormat(d_->formats.front(), d_->max_width, d_->max_height);
  }

  int Open(const std::string&, int) override {
    std::lock_guard<std::mutex> lock(d_->mutex);
    if (!d_->present) {
      if (--d_->unplugged_open_failures < 0) {
        d_->present = true;  // plugged back in
      } else {
        errno = ENOENT;
        return -1;
      }
    }
    ++d_->opens;
    ++d_->open_fds;
    return kFd;
  }

  int Close(int fd) override {
    std::lock_guard<std::mutex> lock(d_->mutex);
    if (fd != kFd) return Errno(EBADF);
    --d_->open_fds;
    StreamOff();
    buffers_.clear();
    return 0;
  }

  int Poll(int fd, short events, int) override {
    std::lock_guard<std::mutex> lock(d_->mutex);
    if (fd != kFd) return Errno(EBADF);
    if (!d_->present) return POLLERR | POLLHUP;
    if (d_->event_pending && (events & POLLPRI)) return POLLPRI;
    if (!d_->faults.empty() && d_->faults.front() == FakeFault::kTimeout) {
      d_->faults.pop_front();
      return 0;
    }
    if (!d_->streaming || d_->error_state) return POLLERR;
    const bool any_queued =
        std::any_of(buffers_.begin(), buffers_.end(), [](const Buffer& b) { return b.queued; });
    return any_queued ? POLLIN : 0;  // nothing queued: starved, as a real driver
  }

  void* Mmap(size_t length, int fd, off_t offset) override {
    std::lock_guard<std::mutex> lock(d_->mutex);
    const size_t index = static_cast<size_t>(offset) >> 12;
    if (fd != kFd || index >= buffers_.size() || length != buffers_[index].memory.size()) {
      errno = EINVAL;
      return MAP_FAILED;
    }
    ++d_->mapped;
    return buffers_[index].memory.data();
  }

  int Munmap(void*, size_t) override {
    std::lock_guard<std::mutex> lock(d_->mutex);
    --d_->mapped;
    return 0;
  }

  int Ioctl(int fd, unsigned long request, void* arg) override {
    std::lock_guard<std::mutex> lock(d_->mutex);
    if (fd != kFd) return Errno(EBADF);
    if (!d_->present) return Errno(ENODEV);
    switch (request) {
      case VIDIOC_QUERYCAP: {
        auto* cap = static_cast<v4l2_capability*>(arg);
        *cap = {};
        std::strcpy(reinterpret_cast<char*>(cap->driver), "fake");
        std::strcpy(reinterpret_cast<char*>(cap->card), "Fake camera");
        std::strcpy(reinterpret_cast<char*>(cap->bus_info), "platform:fake");
        cap->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
        cap->capabilities = cap->device_caps | V4L2_CAP_DEVICE_CAPS;
        return 0;
      }
      case VIDIOC_ENUM_FMT: {
        auto* desc = static_cast<v4l2_fmtdesc*>(arg);
        if (desc->index >= d_->formats.size()) return Errno(EINVAL);
        desc->pixelformat = d_->formats[desc->index];
        return 0;
      }
      case VIDIOC_G_FMT:
        FillFormat(static_cast<v4l2_format*>(arg));
        return 0;
      case VIDIOC_S_FMT: {
        if (!buffers_.empty()) return Errno(EBUSY);
        auto* fmt = static_cast<v4l2_format*>(arg);
        uint32_t fourcc = fmt->fmt.pix.pixelformat;
        if (std::find(d_->formats.begin(), d_->formats.end(), fourcc) == d_->formats.end())
          fourcc = d_->formats.front();  // as drivers do: the nearest they have
        SetFormat(fourcc, std::clamp(static_cast<int>(fmt->fmt.pix.width), 16, d_->max_width),
                  std::clamp(static_cast<int>(fmt->fmt.pix.height), 16, d_->max_height));
        FillFormat(fmt);
        return 0;
      }
      case VIDIOC_G_PARM:
      case VIDIOC_S_PARM: {
        if (!d_->has_timeperframe) return Errno(ENOTTY);
        auto* parm = static_cast<v4l2_streamparm*>(arg);
        if (request == VIDIOC_S_PARM) {
          const auto& tpf = parm->parm.capture.timeperframe;
          if (tpf.numerator == 0 || tpf.denominator == 0) return Errno(EINVAL);
          d_->fps = std::min(d_->max_fps, static_cast<double>(tpf.denominator) / tpf.numerator);
        }
        parm->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
        parm->parm.capture.timeperframe = {1000, static_cast<uint32_t>(d_->fps * 1000)};
        return 0;
      }
      case VIDIOC_REQBUFS: {
        auto* req = static_cast<v4l2_requestbuffers*>(arg);
        if (req->memory != V4L2_MEMORY_MMAP) return Errno(EINVAL);
        if (d_->streaming) return Errno(EBUSY);
        req->count = std::min(req->count, d_->max_buffers);
        buffers_.assign(req->count, Buffer{});
        for (auto& b : buffers_) b.memory.assign(d_->sizeimage, 0);
        return 0;
      }
      case VIDIOC_QUERYBUF: {
        auto* b = static_cast<v4l2_buffer*>(arg);
        if (b->index >= buffers_.size()) return Errno(EINVAL);
        b->length = static_cast<uint32_t>(buffers_[b->index].memory.size());
        b->m.offset = b->index << 12;
        return 0;
      }
      case VIDIOC_QBUF: {
        auto* b = static_cast<v4l2_buffer*>(arg);
        if (b->index >= buffers_.size() || buffers_[b->index].queued) return Errno(EINVAL);
        if (d_->error_state) return Errno(EIO);
        if (buffers_[b->index].out) --d_->outstanding;
        buffers_[b->index].out = false;
        buffers_[b->index].queued = true;
        return 0;
      }
      case VIDIOC_DQBUF:
        return Dequeue(static_cast<v4l2_buffer*>(arg));
      case VIDIOC_STREAMON:
        if (buffers_.empty()) return Errno(EINVAL);
        d_->streaming = true;
        ++d_->streamons;
        return 0;
      case VIDIOC_STREAMOFF:
        StreamOff();
        return 0;
      case VIDIOC_SUBSCRIBE_EVENT:
        return 0;
      case VIDIOC_DQEVENT: {
        if (!d_->event_pending) return Errno(ENOENT);
        d_->event_pending = false;
        auto* event = static_cast<v4l2_event*>(arg);
        *event = {};
        event->type = V4L2_EVENT_SOURCE_CHANGE;
        return 0;
      }
      default:
        return Errno(ENOTTY);
    }
  }

 private:
  struct Buffer {
    std::vector<uint8_t> memory;
    bool queued = false;
    bool out = false;
  };

  static int Errno(int error) {
    errno = error;
    return -1;
  }

  void SetFormat(uint32_t fourcc, int width, int height) {
    width &= ~1;
    height &= ~1;
    d_->fourcc = fourcc;
    d_->width = width;
    d_->height = height;
    const int row = fourcc == V4L2_PIX_FMT_YUYV ? 2 * width : width;
    d_->bytesperline = row + d_->row_padding;
    const uint32_t plane = static_cast<uint32_t>(d_->bytesperline * height);
    d_->sizeimage = fourcc == V4L2_PIX_FMT_NV12 ? plane + plane / 2 : plane;
  }

  void FillFormat(v4l2_format* fmt) const {
    fmt->fmt.pix.pixelformat = d_->fourcc;
    fmt->fmt.pix.width = static_cast<uint32_t>(d_->width);
    fmt->fmt.pix.height = static_cast<uint32_t>(d_->height);
    fmt->fmt.pix.bytesperline = static_cast<uint32_t>(d_->bytesperline);
    fmt->fmt.pix.sizeimage = d_->sizeimage;
    fmt->fmt.pix.field = V4L2_FIELD_NONE;
  }

  void StreamOff() {
    d_->streaming = false;
    d_->error_state = false;
    for (auto& b : buffers_) {
      if (b.out) --d_->outstanding;
      b.queued = b.out = false;
    }
  }

  void Render(Buffer& buffer, uint32_t sequence, size_t* used) {
    const int luma_step = d_->fourcc == V4L2_PIX_FMT_YUYV ? 2 : 1;
    std::fill(buffer.memory.begin(), buffer.memory.end(), 128);
    for (int y = 0; y < d_->height; ++y) {
      uint8_t* row = buffer.memory.data() + static_cast<size_t>(y) * d_->bytesperline;
      for (int x = 0; x < d_->width; ++x)
        row[x * luma_step] =
            static_cast<uint8_t>((x + 2 * y + 3 * static_cast<int>(sequence)) & 0xff);
    }
    *used = d_->sizeimage;
  }

  int Dequeue(v4l2_buffer* out) {
    if (!d_->streaming) return Errno(EINVAL);
    if (d_->error_state) return Errno(EIO);
    bool error_flag = false;
    bool fatal_after = false;
    if (!d_->faults.empty()) {
      const FakeFault fault = d_->faults.front();
      switch (fault) {
        case FakeFault::kEagain:
          d_->faults.pop_front();
          return Errno(EAGAIN);
        case FakeFault::kEio:
          d_->faults.pop_front();
          d_->error_state = true;
          return Errno(EIO);
        case FakeFault::kUnplug:
          d_->faults.pop_front();
          d_->present = false;
          return Errno(ENODEV);
        case FakeFault::kFatalAfter:
          d_->faults.pop_front();
          fatal_after = true;
          break;
        case FakeFault::kErrorFlag:
          d_->faults.pop_front();
          error_flag = true;
          break;
        case FakeFault::kSkip2:
          d_->faults.pop_front();
          d_->sequence += 2;
          break;
        case FakeFault::kFormatChange:
        case FakeFault::kSourceChange: {
          d_->faults.pop_front();
          const int old_size = static_cast<int>(d_->sizeimage);
          SetFormat(d_->fourcc, 320, 240);
          d_->sizeimage = static_cast<uint32_t>(old_size);  // the buffers stay as they were
          SetFormatKeepingBuffers();
          if (fault == FakeFault::kSourceChange) {
            d_->event_pending = true;
            return Errno(EAGAIN);
          }
          break;
        }
        case FakeFault::kTimeout:
          break;  // consumed by Poll
      }
    }
    auto it =
        std::find_if(buffers_.begin(), buffers_.end(), [](const Buffer& b) { return b.queued; });
    if (it == buffers_.end()) return Errno(EAGAIN);
    size_t used = 0;
    const uint32_t sequence = d_->sequence++;
    Render(*it, sequence, &used);
    it->queued = false;
    it->out = true;
    d_->max_outstanding = std::max(d_->max_outstanding, ++d_->outstanding);
    *out = {};
    out->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    out->memory = V4L2_MEMORY_MMAP;
    out->index = static_cast<uint32_t>(it - buffers_.begin());
    out->bytesused = static_cast<uint32_t>(used);
    out->sequence = sequence;
    out->flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | (error_flag ? V4L2_BUF_FLAG_ERROR : 0);
    if (fatal_after) d_->error_state = true;
    const uint64_t ns = 1000000000ull + sequence * 33333333ull;
    out->timestamp.tv_sec = static_cast<time_t>(ns / 1000000000ull);
    out->timestamp.tv_usec = static_cast<suseconds_t>((ns % 1000000000ull) / 1000);
    return 0;
  }

  // After a format switch the frames shrink inside the old buffers.
  void SetFormatKeepingBuffers() {
    const uint32_t plane = static_cast<uint32_t>(d_->bytesperline * d_->height);
    d_->sizeimage = d_->fourcc == V4L2_PIX_FMT_NV12 ? plane + plane / 2 : plane;
  }

  std::shared_ptr<FakeV4l2Driver> d_;
  std::vector<Buffer> buffers_;
};

}  // namespace

std::unique_ptr<V4l2Device> MakeFakeV4l2Device(std::shared_ptr<FakeV4l2Driver> driver) {
  return std::make_unique<FakeV4l2Device>(std::move(driver));
}

}  // namespace dfsm::capture
