// The daemon's view of capture: one frame source (V4L2, libcamera, replay or
// synthetic) streaming continuously into a preallocated ring buffer from a
// thread of its own, with reconnection, and bursts of consecutive frames taken
// out of it on request. This header is the contract between daemon/capture
// (which implements it) and daemon/service (which uses it).
//
// Invariants: capture never blocks on a consumer; no allocation per frame in
// steady state; a burst is N frames with consecutive sequence numbers or an
// error, never a burst with a silent gap.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/io/burst.h"
#include "daemon/capture/replay_source.h"

namespace dfsm::capture {

// A configuration the service cannot use (bad source URI, bad size): the
// message names the key and the problem.
class CaptureConfigError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// A burst that cannot be had now. `reason` names the cause in words a user of
// the REST API can act on ("capture device gone: /dev/video0: No such device").
class CaptureUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CaptureConfig {
  // "v4l2:/dev/video0" (or a /dev/v4l/by-id/ path), "libcamera:<camera id>"
  // ("libcamera:" alone: the first camera), "replay:<burst dir or dir of bursts>",
  // "synthetic:" (a generated scene with known answer).
  std::string source = "replay:";
  int width = 0, height = 0;  // requested size (0: driver default); the driver's answer wins
  double fps = 0.0;           // requested rate (0: default); replay: 0 = recorded rate,
                              // < 0 = as fast as frames are taken
  std::string pixel_format;   // V4L2 fourcc preference ("YUYV", "MJPG", ...); empty: automatic
  bool keep_color = true;     // BGR frames where the source has colour; false: gray only
                              // (cheaper: no chroma conversion, a third of the memory)
  ReplayLoop replay_loop = ReplayLoop::kRestart;  // how a replay: source loops
  int ring_frames = 64;                           // ring capacity, frames
  int device_buffers = 4;  // V4L2 mmap buffers / libcamera requests in flight (>= 4)
  std::chrono::milliseconds frame_timeout{2000};  // no frame for this long: reopen
  std::chrono::milliseconds reconnect_backoff{1000};
};

struct CaptureStatus {
  std::string source;  // as configured
  std::string device, driver, card;
  std::string format;  // fourcc or libcamera pixel format as negotiated
  int width = 0, height = 0;
  double fps = 0.0;        // negotiated (or measured) rate
  bool streaming = false;  // frames arrived within frame_timeout
  uint64_t frames_captured = 0;
  uint64_t frames_dropped = 0;  // sequence gaps + buffers flagged with errors
  uint64_t reconnects = 0;
  int ring_fill = 0, ring_capacity = 0;
  std::string last_error;  // empty when none
  int64_t last_frame_monotonic_ns = 0;
};

// The status as the REST API and dfsm-capture report it; last_error is null
// when there is none.
nlohmann::json ToJson(const CaptureStatus& status);

enum class BurstWhen { kLast, kNext };

struct CapturedFrame {
  int64_t sequence = 0;
  int64_t timestamp_ns = 0;     // CLOCK_MONOTONIC
  cv::Mat gray;                 // CV_8UC1 (a burst copy of a colour frame leaves it empty)
  cv::Mat color;                // CV_8UC3 BGR where the source has colour, else empty
  int64_t source_sequence = 0;  // the driver's own sequence (replay: index in its burst)
};

class CaptureService {
 public:
  // Throws CaptureConfigError for a configuration that can never work.
  static std::unique_ptr<CaptureService> Create(const CaptureConfig& config);
  virtual ~CaptureService() = default;

  // Starts the capture thread; returns at once. Device errors do not throw:
  // they show in Status() and the service keeps retrying.
  virtual void Start() = 0;
  // Stops and joins the capture thread. Idempotent.
  virtual void Stop() = 0;

  virtual CaptureStatus Status() const = 0;

  // N consecutive frames: the last N already in the ring (kLast) or the next N
  // to arrive (kNext, waiting at most `timeout`). The frames are copies owned by
  // the caller, in capture order; manifest.source carries the provenance
  // (device, driver, card, format, fps, exposure where known, sequence range).
  // Throws CaptureUnavailable (not streaming, too few frames, gap, timeout).
  struct Burst {
    BurstManifest manifest;       // frames[].file empty; WriteBurst fills them in
    std::vector<cv::Mat> frames;  // BGR8 if the source has colour, else gray8
  };
  virtual Burst GrabBurst(int frames, BurstWhen when, std::chrono::milliseconds timeout) = 0;

  // The newest frame, if any (for /api/v1/snapshot.jpg).
  virtual std::optional<CapturedFrame> LatestFrame() const = 0;
};

}  // namespace dfsm::capture
