// The camera as the service layer sees it: health, a description, the newest
// frame and a burst. The service and the API know only this port; the
// composition root (dfsmd/) plugs the capture layer in behind it
// (dfsmd/capture_camera.h), so neither daemon/service/ nor api/ includes or
// links daemon/capture/.
#pragma once

#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/io/burst.h"
#include "daemon/service/burst_when.h"

namespace dfsm::service {

// No burst or frame can be had now (not streaming, too few frames, a gap, a
// timeout, no camera at all); the message names the cause.
class CameraUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CameraHealth {
  bool streaming = false;
  std::string last_error;          // empty when none
  int64_t last_frame_age_ns = -1;  // since the newest frame; -1: none yet
  uint64_t frames_captured = 0;
  uint64_t frames_dropped = 0;
  uint64_t reconnects = 0;
  int ring_fill = 0;
};

struct CameraBurst {
  BurstManifest manifest;       // frames[].file empty; WriteBurst fills them in
  std::vector<cv::Mat> frames;  // BGR8 where the camera has colour, else gray8
};

class CameraPort {
 public:
  virtual ~CameraPort() = default;

  virtual CameraHealth Health() const = 0;
  // The camera's state as GET /api/v1/camera reports it.
  virtual nlohmann::json Describe() const = 0;
  // The newest frame (colour where the camera has it); empty when none.
  virtual cv::Mat NewestFrame() const = 0;
  // `frames` consecutive frames: the last ones already taken (kLast) or the
  // next ones (kNext, waiting at most `timeout`). Throws CameraUnavailable.
  virtual CameraBurst GrabBurst(int frames, BurstWhen when, std::chrono::milliseconds timeout) = 0;
};

}  // namespace dfsm::service
