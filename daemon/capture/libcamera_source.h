// A libcamera camera (Debian 12 ships libcamera 0.0.3: UVC and vimc on amd64,
// the Raspberry Pi cameras on arm64). Built only where pkg-config finds
// libcamera.
//
// Threads: libcamera completes requests in its own thread. That thread only
// appends the request to a queue under a mutex and signals; conversion and
// re-queueing (Request::ReuseBuffers) happen in the capture thread's Read().
// At least four requests stay in flight.
#pragma once

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "daemon/capture/capture_service.h"
#include "daemon/capture/frame_source.h"
#include "daemon/capture/mjpeg_decoder.h"
#include "daemon/capture/pixel_convert.h"
#include "daemon/capture/v4l2_device.h"

namespace libcamera {
class Camera;
class CameraManager;
class FrameBufferAllocator;
class Request;
class Stream;
}  // namespace libcamera

namespace dfsm::capture {

class LibcameraSource : public FrameSource {
 public:
  // `camera_id`: a libcamera camera id, or empty for the first camera.
  LibcameraSource(std::string camera_id, const CaptureConfig& config);
  ~LibcameraSource() override;

  void Open() override;
  void Close() override;
  ReadResult Read(FrameSlot& slot, std::chrono::milliseconds timeout) override;
  SourceDescription Describe() const override;
  void HoldControls(bool hold) override;

 private:
  struct Mapping {
    void* address = nullptr;
    size_t length = 0;
  };
  void OnRequestCompleted(libcamera::Request* request);  // libcamera's thread
  void OnDisconnected();                                 // libcamera's thread
  [[noreturn]] void Fail(SourceError::Kind kind, const std::string& what) const;
  const uint8_t* PlaneData(const libcamera::Request* request) const;

  const std::string camera_id_;
  const CaptureConfig config_;
  std::unique_ptr<libcamera::CameraManager> manager_;
  std::shared_ptr<libcamera::Camera> camera_;
  bool acquired_ = false, started_ = false;
  std::unique_ptr<libcamera::FrameBufferAllocator> allocator_;
  libcamera::Stream* stream_ = nullptr;
  std::vector<std::unique_ptr<libcamera::Request>> requests_;
  std::vector<Mapping> mappings_;      // per request: the whole dmabuf of its buffer
  std::vector<size_t> plane_offsets_;  // per request: offset of plane 0 in the mapping
  FrameLayout layout_;
  std::string format_name_;
  double fps_ = 0.0;
  std::unique_ptr<MjpegDecoder> mjpeg_;
  bool have_sequence_ = false;
  unsigned int last_sequence_ = 0;
  uint64_t dropped_pending_ = 0;  // lost since the last frame handed out
  int hold_ = -1;                 // -1: nothing to apply; 0/1: release/hold on the next requests

  std::mutex mutex_;  // guards the two fields below (shared with libcamera's thread)
  std::condition_variable completed_cv_;
  std::deque<libcamera::Request*> completed_;
  bool disconnected_ = false;
};

}  // namespace dfsm::capture
