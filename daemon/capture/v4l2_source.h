// A V4L2 capture device (UVC webcams, CSI bridges, HDMI grabbers, vivid):
// non-blocking open, format negotiation that takes the driver's answer,
// memory-mapped streaming with every dequeued buffer queued again on every
// path, and a clear error for each way a device fails.
//
// Failure handling (the service reopens after any SourceError):
//   EAGAIN after poll        spurious wake-up: poll again
//   V4L2_BUF_FLAG_ERROR      queue the buffer again, count one dropped frame
//   sequence gap             count the missing frames as dropped
//   EIO (DQBUF or QBUF)      restart streaming in place (STREAMOFF/STREAMON);
//                            SourceError(kIo) if that fails too
//   ENODEV / POLLERR         SourceError(kGone): the device was unplugged
//   source-change event, or  SourceError(kIo): the driver changed the format;
//   a frame of another size  the reopen negotiates again
#pragma once

#include <linux/videodev2.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "daemon/capture/capture_service.h"
#include "daemon/capture/frame_source.h"
#include "daemon/capture/mjpeg_decoder.h"
#include "daemon/capture/pixel_convert.h"
#include "daemon/capture/v4l2_device.h"

namespace dfsm::capture {

class V4l2Source : public FrameSource {
 public:
  struct Options {
    std::string path;  // /dev/videoN or a /dev/v4l/by-id/ link
    int width = 0, height = 0;
    double fps = 0.0;
    std::string fourcc;  // preferred format; empty: automatic
    int buffers = 4;
    bool keep_color = true;  // BGR for the formats where it is cheap (not MJPEG)
    // Where stable names are looked for; a test points it elsewhere.
    std::string by_id_dir = "/dev/v4l/by-id";
    static Options FromConfig(const std::string& path, const CaptureConfig& config);
  };

  V4l2Source(Options options, std::unique_ptr<V4l2Device> device);
  ~V4l2Source() override;

  void Open() override;
  void Close() override;
  ReadResult Read(FrameSlot& slot, std::chrono::milliseconds timeout) override;
  SourceDescription Describe() const override;

  // Counters for tests and status details.
  int stream_restarts() const { return stream_restarts_; }

 private:
  struct MappedBuffer {
    void* start = nullptr;
    size_t length = 0;
  };

  [[noreturn]] void Fail(SourceError::Kind kind, const std::string& what, int error) const;
  [[noreturn]] void FailIoctl(const char* name, int error) const;
  int Xioctl(unsigned long request, void* arg, const char* name);  // throws on failure
  std::string ResolveStablePath();
  void QueryCapabilities();
  std::vector<uint32_t> EnumerateFormats();
  void NegotiateFormat();
  void ApplyFormat(uint32_t fourcc);  // S_FMT + S_PARM; the driver's answer in layout_, fps_
  void SetFrameRate();
  void StartStreaming();
  void StopStreaming();
  void RestartStreaming();
  void QueueBuffer(uint32_t index);  // throws on any failure (setting up)
  bool Requeue(uint32_t index);      // false: EIO, the stream was restarted
  void CheckFormatUnchanged();
  void HandleEvents();

  const Options options_;
  const std::unique_ptr<V4l2Device> device_;
  std::string opened_path_;  // what was opened (the stable link when one exists)
  std::string stable_path_;  // the by-id link found at the first open, reused later
  int fd_ = -1;
  std::string driver_, card_, bus_info_;
  FrameLayout layout_;
  double fps_ = 0.0;
  std::vector<MappedBuffer> buffers_;
  bool streaming_ = false;
  bool events_ = false;  // subscribed to source-change events
  bool have_sequence_ = false;
  uint32_t last_sequence_ = 0;
  uint64_t dropped_pending_ = 0;
  bool discontinuity_pending_ = false;
  int stream_restarts_ = 0;
  std::unique_ptr<MjpegDecoder> mjpeg_;
};

}  // namespace dfsm::capture
