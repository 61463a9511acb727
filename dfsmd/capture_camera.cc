#include "dfsmd/capture_camera.h"

#include <time.h>

namespace dfsm::daemon {
namespace {

int64_t MonotonicNs() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<int64_t>(now.tv_sec) * 1000000000LL + now.tv_nsec;
}

}  // namespace

service::CameraHealth CaptureCamera::Health() const {
  const capture::CaptureStatus status = capture_->Status();
  service::CameraHealth health;
  health.streaming = status.streaming;
  health.last_error = status.last_error;
  health.last_frame_age_ns =
      status.last_frame_monotonic_ns == 0 ? -1 : MonotonicNs() - status.last_frame_monotonic_ns;
  health.frames_captured = status.frames_captured;
  health.frames_dropped = status.frames_dropped;
  health.reconnects = status.reconnects;
  health.ring_fill = status.ring_fill;
  return health;
}

nlohmann::json CaptureCamera::Describe() const { return capture::ToJson(capture_->Status()); }

cv::Mat CaptureCamera::NewestFrame() const {
  const std::optional<capture::CapturedFrame> frame = capture_->LatestFrame();
  if (!frame) return {};
  return frame->color.empty() ? frame->gray : frame->color;
}

service::CameraBurst CaptureCamera::GrabBurst(int frames, service::BurstWhen when,
                                              std::chrono::milliseconds timeout) {
  try {
    capture::CaptureService::Burst burst = capture_->GrabBurst(
        frames,
        when == service::BurstWhen::kNext ? capture::BurstWhen::kNext : capture::BurstWhen::kLast,
        timeout);
    return {std::move(burst.manifest), std::move(burst.frames)};
  } catch (const capture::CaptureUnavailable& e) {
    throw service::CameraUnavailable(e.what());
  }
}

}  // namespace dfsm::daemon
