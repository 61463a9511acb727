// Which frames a capture takes, in a header of its own so that the camera
// port (camera_port.h), the configuration (config.h, pipeline.when) and a
// job's options (job.h) share one enum without including each other.
#pragma once

#include <string>

namespace dfsm::service {

// kLast: the frames already in the ring; kNext: the frames still to come.
enum class BurstWhen { kLast, kNext };

const char* BurstWhenName(BurstWhen when);  // "last" | "next"
// Throws std::invalid_argument for a name that is neither.
BurstWhen ParseBurstWhen(const std::string& name);

}  // namespace dfsm::service
