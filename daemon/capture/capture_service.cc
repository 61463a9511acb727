// CaptureService::Create: checks the configuration and picks the frame source
// named by the URI's scheme.
#include "daemon/capture/capture_service.h"

#include <cmath>
#include <filesystem>

#include "daemon/capture/replay_source.h"
#include "daemon/capture/source_uri.h"
#include "daemon/capture/streaming_service.h"
#include "daemon/capture/v4l2_source.h"
#include "daemon/capture/capture_limits.h"
#ifdef DFSM_HAVE_LIBCAMERA
#include "daemon/capture/libcamera_source.h"
#endif
#ifdef DFSM_HAVE_SYNTH
#include "daemon/capture/synthetic_source.h"
#endif

namespace dfsm::capture {

namespace {

void CheckConfig(const CaptureConfig& config) {
  const auto fail = [](const std::string& message) { throw CaptureConfigError(message); };
  if (config.width < 0 || config.height < 0)
    fail("capture size " + std::to_string(config.width) + "x" + std::to_string(config.height) +
         " is negative");
  if ((config.width == 0) != (config.height == 0))
    fail("capture width and height must be given together (or both 0 for the default)");
  const auto check_range = [&](const char* name, int value, int min, int max) {
    if (value < min || value > max)
      fail(std::string(name) + " " + std::to_string(value) + " is outside " + std::to_string(min) +
           ".." + std::to_string(max));
  };
  check_range("ring_frames", config.ring_frames, kMinRingFrames, kMaxRingFrames);
  check_range("device_buffers", config.device_buffers, kMinDeviceBuffers, kMaxDeviceBuffers);
  if (config.frame_timeout.count() <= 0) fail("frame_timeout must be positive");
  if (config.reconnect_backoff.count() < 0) fail("reconnect_backoff must not be negative");
  if (!std::isfinite(config.fps)) fail("fps must be a finite number");
}

}  // namespace

std::unique_ptr<CaptureService> CaptureService::Create(const CaptureConfig& config) {
  CheckConfig(config);
  const SourceUri uri = ParseSourceUri(config.source);  // throws CaptureConfigError
  std::unique_ptr<FrameSource> source;
  if (uri.scheme == "replay") {
    if (uri.path.empty())
      throw CaptureConfigError("source \"" + config.source +
                               "\": replay needs a burst directory, e.g. replay:/var/lib/dfsm/b1");
    try {
      ReplaySource::FindBursts(uri.path);
    } catch (const SourceError& e) {
      throw CaptureConfigError(std::string("source: ") + e.what());
    }
    source =
        std::make_unique<ReplaySource>(uri.path, config.fps, config.keep_color, config.replay_loop);
  } else if (config.fps < 0) {
    throw CaptureConfigError("fps " + std::to_string(config.fps) +
                             " is negative: only a replay can run unpaced");
  } else if (uri.scheme == "v4l2") {
    if (uri.path.empty())
      throw CaptureConfigError("source \"" + config.source +
                               "\": v4l2 needs a device path, e.g. v4l2:/dev/video0");
    source = std::make_unique<V4l2Source>(V4l2Source::Options::FromConfig(uri.path, config),
                                          MakeSystemV4l2Device());
  } else if (uri.scheme == "libcamera") {
#ifdef DFSM_HAVE_LIBCAMERA
    source = std::make_unique<LibcameraSource>(uri.path, config);
#else
    throw CaptureConfigError("source \"" + config.source +
                             "\": this build has no libcamera support (libcamera-dev was not "
                             "found when it was built)");
#endif
  } else if (uri.scheme == "synthetic") {
#ifdef DFSM_HAVE_SYNTH
    source = std::make_unique<SyntheticSource>(config);
#else
    throw CaptureConfigError("source \"" + config.source +
                             "\": this build has no synthetic source (core/synth missing)");
#endif
  }
  return std::make_unique<StreamingCaptureService>(config, std::move(source));
}

nlohmann::json ToJson(const CaptureStatus& s) {
  return {
      {"source", s.source},
      {"device", s.device},
      {"driver", s.driver},
      {"card", s.card},
      {"format", s.format},
      {"width", s.width},
      {"height", s.height},
      {"fps", s.fps},
      {"streaming", s.streaming},
      {"frames_captured", s.frames_captured},
      {"frames_dropped", s.frames_dropped},
      {"reconnects", s.reconnects},
      {"ring_fill", s.ring_fill},
      {"ring_capacity", s.ring_capacity},
      {"last_error", s.last_error.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.last_error)},
      {"last_frame_monotonic_ns", s.last_frame_monotonic_ns}};
}

}  // namespace dfsm::capture
