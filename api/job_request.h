// Validation of what a client asks a job to do: the JSON body of
// POST /api/v1/captures and the query of POST /api/v1/jobs. Every field has
// the daemon's [pipeline] default; unknown fields and bad values are errors
// that name the field, so a typo is never silently ignored.
#pragma once

#include <map>
#include <stdexcept>
#include <string>

#include "daemon/service/config.h"
#include "daemon/service/job.h"

namespace dfsm::api {

class RequestError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

service::JobOptions DefaultJobOptions(const service::DaemonConfig& config);

// {"frames","when","planes","grid","init","dense","keep_burst"}, all optional;
// an empty body means the defaults. frames may not exceed the capture ring.
service::JobOptions ParseCaptureRequest(const std::string& body,
                                        const service::DaemonConfig& config);

// ?frames=&planes=&grid=&init=&dense=&keep_burst= (no "when"); frames absent
// or 0: every frame of the upload.
service::JobOptions ParseUploadQuery(const std::multimap<std::string, std::string>& query,
                                     const service::DaemonConfig& config);

struct ListQuery {
  int limit = 20;
  std::string after;   // a job id: list the jobs older than it
  std::string status;  // empty: any
};
ListQuery ParseListQuery(const std::multimap<std::string, std::string>& query);

// ?width= of GET /api/v1/snapshot.jpg: the frame scaled down to this many
// pixels wide (a live view on a phone needs a fraction of a 1080p frame).
struct SnapshotQuery {
  static constexpr int kMinWidth = 16;
  static constexpr int kMaxWidth = 8192;
  int width = 0;  // 0: as captured; wider than the frame: as captured
};
SnapshotQuery ParseSnapshotQuery(const std::multimap<std::string, std::string>& query);

}  // namespace dfsm::api
