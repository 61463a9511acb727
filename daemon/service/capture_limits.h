// Limits on the camera's configuration, on the service's side of the camera
// port: dfsmd's options table (config_keys.cc) and the capture layer that
// implements the port (daemon/capture/capture_service.cc) read the same
// constants, so --check-config accepts exactly what start-up accepts.
#pragma once

namespace dfsm::service {

inline constexpr int kMinRingFrames = 3;  // a burst needs three frames
inline constexpr int kMaxRingFrames = 4096;
// Fewer than four buffers drop frames at 30 fps on every driver tried; the
// kernel's VIDEO_MAX_FRAME (videodev2.h) allows 32.
inline constexpr int kMinDeviceBuffers = 4;
inline constexpr int kMaxDeviceBuffers = 32;

}  // namespace dfsm::service
