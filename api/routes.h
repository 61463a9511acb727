// The REST API (/api/v1/..., /healthz, /readyz, /metrics): maps HTTP requests
// to the service layer and its errors to problem+json. Handlers do quick work
// only: a capture request copies frames from the ring and stores them, an
// upload is parsed and stored; the pipeline itself runs on the scheduler's
// workers, never on an HTTP thread.
#pragma once

#include <httplib.h>

#include "api/http_server.h"
#include "daemon/service/calibration_keeper.h"
#include "daemon/service/camera_port.h"
#include "daemon/service/config.h"
#include "daemon/service/job_intake.h"
#include "daemon/service/job_scheduler.h"
#include "daemon/service/job_store.h"
#include "daemon/service/metrics.h"

namespace dfsm::api {

// What the routes work on; owned by the daemon, which outlives the server.
struct ApiContext {
  const service::DaemonConfig* config = nullptr;
  service::JobStore* store = nullptr;
  service::JobScheduler* scheduler = nullptr;
  service::JobIntake* intake = nullptr;
  service::CameraPort* camera = nullptr;  // may be null (no capture source)
  service::Metrics* metrics = nullptr;
  service::CalibrationKeeper* calibration = nullptr;  // may be null (no fusion)
};

// Registers every route, the CORS headers when configured, and the error and
// exception handlers that turn anything else into problem+json; sets the
// server's request guard (request_guard.h) from the configuration.
void RegisterRoutes(const ApiContext& context, HttpServer* server);

// A resource and its methods; `path` as OpenAPI writes it ({id}: one path
// segment; {path}: the rest). api/openapi.json documents each of them
// (openapi_test.cc), the web page's files under /ui/ excepted.
struct ApiResource {
  std::string path;
  std::string methods;  // "GET, HEAD, DELETE": the Allow header of a 405
};
const std::vector<ApiResource>& ApiResources();

// The methods of the resource `path` matches, "" for none.
std::string AllowedMethods(const std::string& path);

// A job as the API shows it: its record, its progress (0..1) and its links.
nlohmann::json JobJson(const service::Job& job);

// The files of a job (GET /api/v1/jobs/{id}/{file}).
std::vector<std::string> JobFileNames();

// Content type of a job file, or nullptr when `file` is not a job file.
const char* JobFileContentType(const std::string& file);

}  // namespace dfsm::api
