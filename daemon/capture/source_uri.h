// Parsing of the capture source URI ("v4l2:/dev/video0", "replay:/dir", ...).
#pragma once

#include <string>

namespace dfsm::capture {

struct SourceUri {
  std::string scheme;  // "v4l2", "libcamera", "replay", "synthetic"
  std::string path;    // the rest after the colon; may be empty
};

// Throws CaptureConfigError naming the URI when the scheme is missing or unknown.
SourceUri ParseSourceUri(const std::string& uri);

}  // namespace dfsm::capture
