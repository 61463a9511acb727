// The capture layer behind the service's camera port (daemon/service/
// camera_port.h): the one place where capture::CaptureService meets the
// service and the API.
#pragma once

#include "daemon/capture/capture_service.h"
#include "daemon/service/camera_port.h"

namespace dfsm::daemon {

class CaptureCamera final : public service::CameraPort {
 public:
  // `capture` outlives this.
  explicit CaptureCamera(capture::CaptureService* capture) : capture_(capture) {}

  service::CameraHealth Health() const override;
  nlohmann::json Describe() const override;
  cv::Mat NewestFrame() const override;
  service::CameraBurst GrabBurst(int frames, service::BurstWhen when,
                                 std::chrono::milliseconds timeout) override;

 private:
  capture::CaptureService* capture_;
};

}  // namespace dfsm::daemon
