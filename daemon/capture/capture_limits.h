// Limits on the capture layer's configuration (CaptureService::Create checks
// them). dfsmd's options table (daemon/service/config_keys.cc) states the same
// ranges for --check-config, on its side of the camera port; the composition
// root's test (dfsmd/config_wiring_test.cc) holds the two together.
#pragma once

namespace dfsm::capture {

inline constexpr int kMinRingFrames = 3;  // a burst needs three frames
inline constexpr int kMaxRingFrames = 4096;
// Fewer than four buffers drop frames at 30 fps on every driver tried; the
// kernel's VIDEO_MAX_FRAME (videodev2.h) allows 32.
inline constexpr int kMinDeviceBuffers = 4;
inline constexpr int kMaxDeviceBuffers = 32;

}  // namespace dfsm::capture
