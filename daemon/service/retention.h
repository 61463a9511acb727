// Which finished jobs to delete so that the state directory stays within its
// limits. A pure function of the job list, so the policy is tested without disk.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "daemon/service/config.h"
#include "daemon/service/job.h"

namespace dfsm::service {

// Jobs that are queued or processing are never selected, whatever the limits:
// their burst is the only copy of a capture the user asked for. Of the finished
// jobs the newest succeeded ones are kept while they fit all three limits
// (count, bytes, age), then the newest failed ones in the room left; the rest
// are returned, oldest first (by id, which sorts by creation).
std::vector<std::string> SelectExpiredJobs(const std::vector<Job>& jobs,
                                           const RetentionSection& limits, int64_t now_ms);

}  // namespace dfsm::service
