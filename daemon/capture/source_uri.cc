#include "daemon/capture/source_uri.h"

#include "daemon/capture/capture_service.h"

namespace dfsm::capture {

SourceUri ParseSourceUri(const std::string& uri) {
  const size_t colon = uri.find(':');
  if (colon == std::string::npos)
    throw CaptureConfigError("source \"" + uri +
                             "\" has no scheme: expected v4l2:, libcamera:, replay: or synthetic:");
  SourceUri parsed{uri.substr(0, colon), uri.substr(colon + 1)};
  if (parsed.scheme != "v4l2" && parsed.scheme != "libcamera" && parsed.scheme != "replay" &&
      parsed.scheme != "synthetic")
    throw CaptureConfigError("source \"" + uri + "\": unknown scheme \"" + parsed.scheme +
                             "\" (expected v4l2, libcamera, replay or synthetic)");
  return parsed;
}

}  // namespace dfsm::capture
