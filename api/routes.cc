#include "api/routes.h"

#include <sys/statvfs.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <opencv2/imgproc.hpp>
#include <regex>
#include <thread>

#include "api/bearer_auth.h"
#include "api/file_response.h"
#include "api/job_request.h"
#include "api/openapi.h"
#include "api/problem.h"
#include "api/request_body.h"
#include "api/www_files.h"
#include "core/io/file_util.h"
#include "core/io/jpeg_encode.h"
#include "daemon/service/tar_writer.h"

namespace dfsm::api {
namespace {

using service::Job;
using service::JobStatus;

constexpr const char* kJobFiles[][2] = {
    {"result.json", "application/json"},
    {"depth.tiff", "image/tiff"},
    {"depth_filled.tiff", "image/tiff"},
    {"depth.png", "image/png"},
    {"preview.png", "image/png"},
    {"confidence.png", "image/png"},
    {"points.ply", "application/octet-stream"},  // binary PLY has no registered type
    {"sparse_points.ply", "application/octet-stream"},
    {"calibration.json", "application/json"},
    {"calibration.yaml", "application/yaml"},
    {"burst.tar", "application/x-tar"},
};

void SetJson(httplib::Response& response, int status, const nlohmann::json& body) {
  response.status = status;
  response.set_content(body.dump(2) + "\n", kJsonContentType);
}

std::string JobPath(const std::string& id) { return "/api/v1/jobs/" + id; }

}  // namespace

nlohmann::json JobJson(const Job& job) {
  nlohmann::json json = service::ToJson(job);
  json["progress"] = service::JobProgress(job);
  nlohmann::json links = {{"self", JobPath(job.id)}};
  if (IsFinished(job.status)) {
    nlohmann::json files = nlohmann::json::array();
    files.push_back(JobPath(job.id) + "/result.json");
    if (job.status == JobStatus::kSucceeded) {
      for (const auto& file : kJobFiles) {
        const std::string name = file[0];
        if (name != "result.json" && name != "burst.tar")
          files.push_back(JobPath(job.id) + "/" + name);
      }
    }
    links["files"] = files;
  }
  if (job.has_burst) links["burst"] = JobPath(job.id) + "/burst.tar";
  json["links"] = links;
  return json;
}

namespace {

void NoSuchJob(httplib::Response& response, const std::string& id) {
  SetProblem(response, 404, "unknown-job", "Unknown job",
             service::IsValidJobId(id) ? "there is no job '" + id + "' (deleted or never created)"
                                       : "'" + id + "' is not a job id");
}

void Accepted(httplib::Response& response, const Job& job) {
  response.set_header("Location", JobPath(job.id));
  SetJson(response, 202, {{"id", job.id}, {"status", JobStatusName(job.status)}});
}

void QueueFull(const ApiContext& context, httplib::Response& response, const std::string& what) {
  response.set_header("Retry-After", std::to_string(context.config->jobs.retry_after_s));
  SetProblem(response, 503, "queue-full", "Job queue full",
             what + "; retry after " + std::to_string(context.config->jobs.retry_after_s) + " s");
}

// The request was fine; the state directory could not take the burst (full,
// read-only, gone). Nothing was stored.
void StorageFailed(const ApiContext& context, httplib::Response& response,
                   const std::string& what) {
  SetProblem(response, 507, "storage-failed", "Cannot store the burst",
             HideStateDirectory(what, context.config->jobs.state_dir));
}

// --- handlers --------------------------------------------------------------

void PostCapture(const ApiContext& context, const httplib::Request& request,
                 httplib::Response& response) {
  service::JobOptions options;
  try {
    options = ParseCaptureRequest(request.body, *context.config);
  } catch (const RequestError& e) {
    return SetProblem(response, 400, "invalid-request", "Invalid capture request", e.what());
  }
  try {
    const Job job = context.intake->FromCapture(
        options, std::chrono::milliseconds(context.config->pipeline.burst_timeout_ms));
    Accepted(response, job);
  } catch (const service::QueueFull& e) {
    QueueFull(context, response, e.what());
  } catch (const service::CameraUnavailable& e) {
    response.set_header("Retry-After", "1");
    SetProblem(response, 503, "capture-unavailable", "No burst available", e.what());
  } catch (const service::JobStoreError& e) {
    StorageFailed(context, response, e.what());
  }
}

// The queue place is taken before the body is read (a full queue answers 503
// at once) and the body goes straight to a staging file (no upload is held in
// memory); the frames are decoded by the job.
void PostJob(const ApiContext& context, const httplib::Request& request,
             httplib::Response& response, const httplib::ContentReader& reader) {
  service::JobOptions options;
  try {
    options = ParseUploadQuery(request.params, *context.config);
  } catch (const RequestError& e) {
    return SetProblem(response, 400, "invalid-request", "Invalid upload options", e.what());
  }
  if (!HasBody(request) || request.get_header_value("Content-Length") == "0") {
    return SetProblem(response, 400, "invalid-upload", "Empty upload",
                      "the body must be a tar of a dfsm-burst/1 directory");
  }
  try {
    service::PendingUpload upload = context.intake->BeginUpload();
    if (!ReadBody(request, reader, static_cast<size_t>(context.config->server.max_body_bytes),
                  response,
                  [&upload](const char* data, size_t size) { upload.Append(data, size); }))
      return;
    if (upload.size() == 0) {
      return SetProblem(response, 400, "invalid-upload", "Empty upload",
                        "the body must be a tar of a dfsm-burst/1 directory");
    }
    Accepted(response, context.intake->FromUpload(std::move(upload), options));
  } catch (const service::QueueFull& e) {
    QueueFull(context, response, e.what());
  } catch (const service::BadUpload& e) {
    SetProblem(response, 422, "invalid-burst", "Upload is not a usable burst",
               HideStateDirectory(e.what(), context.config->jobs.state_dir));
  } catch (const service::JobStoreError& e) {
    StorageFailed(context, response, e.what());
  }
}

void ListJobs(const ApiContext& context, const httplib::Request& request,
              httplib::Response& response) {
  ListQuery query;
  try {
    query = ParseListQuery(request.params);
  } catch (const RequestError& e) {
    return SetProblem(response, 400, "invalid-request", "Invalid list query", e.what());
  }
  nlohmann::json jobs = nlohmann::json::array();
  std::string last;
  bool more = false;
  for (const Job& job : context.store->List()) {  // newest first
    if (!query.after.empty() && job.id >= query.after) continue;
    if (!query.status.empty() && query.status != JobStatusName(job.status)) continue;
    if (static_cast<int>(jobs.size()) == query.limit) {
      more = true;
      break;
    }
    jobs.push_back(JobJson(job));
    last = job.id;
  }
  nlohmann::json body = {{"jobs", jobs}, {"next", nullptr}};
  if (more) {
    std::string next = "/api/v1/jobs?limit=" + std::to_string(query.limit) + "&after=" + last;
    if (!query.status.empty()) next += "&status=" + query.status;
    body["next"] = next;
    response.set_header("Link", "<" + next + ">; rel=\"next\"");
  }
  SetJson(response, 200, body);
}

void GetJob(const ApiContext& context, const httplib::Request& request,
            httplib::Response& response) {
  const std::string id = request.matches[1];
  const std::optional<Job> job = context.store->Get(id);
  if (!job) return NoSuchJob(response, id);
  SetJson(response, 200, JobJson(*job));
}

void DeleteJob(const ApiContext& context, const httplib::Request& request,
               httplib::Response& response) {
  const std::string id = request.matches[1];
  const std::optional<Job> job = context.store->Get(id);
  if (!job) return NoSuchJob(response, id);
  // An unfinished job is deleted only if it can be taken out of the queue: one
  // a worker has just picked up is in progress.
  if (!IsFinished(job->status) && !context.scheduler->RemoveQueued(id)) {
    return SetProblem(response, 409, "job-in-progress", "Job in progress",
                      "job " + id + " is being processed; delete it once it has finished");
  }
  context.store->Remove(id);
  response.status = 204;
}

void GetJobFile(const ApiContext& context, const httplib::Request& request,
                httplib::Response& response) {
  const std::string id = request.matches[1];
  const std::string file = request.matches[2];
  const char* content_type = JobFileContentType(file);
  if (!content_type) {
    std::string names;
    for (const std::string& name : JobFileNames()) names += (names.empty() ? "" : ", ") + name;
    return SetProblem(response, 404, "unknown-file", "No such job file",
                      "'" + file + "' is not a job file (" + names + ")");
  }
  const std::optional<Job> job = context.store->Get(id);
  if (!job) return NoSuchJob(response, id);
  try {
    if (file == "burst.tar") {
      if (!job->has_burst) {
        return SetProblem(response, 410, "burst-deleted", "Burst not kept",
                          "job " + id + " was run with keep_burst false; its burst is deleted");
      }
      // Chunked, written by libarchive as it goes: never the whole burst in memory.
      response.status = 200;  // a Range gets all of it, not a 206 without Content-Range
      auto tar = std::make_shared<service::DirectoryTar>(context.store->BurstDir(id));
      response.set_chunked_content_provider(content_type, [tar](size_t, httplib::DataSink& sink) {
        try {
          const std::string piece = tar->Next();
          if (piece.empty()) sink.done();
          return piece.empty() || sink.write(piece.data(), piece.size());
        } catch (const std::exception&) {
          return false;  // a file vanished mid-download: the connection ends
        }
      });
      return;
    }
    if (!IsFinished(job->status)) {
      response.set_header("Retry-After", "1");
      return SetProblem(response, 409, "job-not-finished", "Job not finished",
                        "job " + id + " is " + JobStatusName(job->status) +
                            "; its files appear when it has finished");
    }
    const std::filesystem::path path = context.store->OutputDir(id) / file;
    if (!std::filesystem::is_regular_file(path)) {
      return SetProblem(response, 404, "file-not-produced", "File not produced",
                        job->status == JobStatus::kFailed
                            ? "job " + id + " failed (" + job->error + "); it has no " + file
                            : "job " + id + " did not produce " + file);
    }
    ServeFile(request, response, path, content_type);
  } catch (const std::exception& e) {
    // Deleted by retention or DELETE between the lookup and the read.
    SetProblem(response, 404, "file-gone", "File no longer available",
               HideStateDirectory(e.what(), context.config->jobs.state_dir));
  }
}

void GetCalibration(const ApiContext& context, httplib::Response& response) {
  // The newest successful job (it saw the camera as it is now: focus, zoom),
  // and the fusion of every job's estimate with its sigma and history.
  const std::optional<Job> job = context.store->LatestSucceeded();
  nlohmann::json body = nlohmann::json::object();
  if (context.calibration) {
    body["fused"] = context.calibration->Snapshot();
    body["joint"] = context.calibration->JointSnapshot();
  }
  if (!job) {
    // No calibration yet is the camera's state, not a missing resource.
    body["calibration"] = nullptr;
    return SetJson(response, 200, body);
  }
  try {
    const nlohmann::json result =
        nlohmann::json::parse(ReadFileToString(context.store->OutputDir(job->id) / "result.json"));
    body.update({{"job", job->id},
                 {"finished_ms", job->finished_ms},
                 {"calibration", result.at("calibration")},
                 {"rms_reprojection_px", result.value("bundle_adjustment", nlohmann::json::object())
                                             .value("rms_reprojection_px", 0.0)},
                 {"links",
                  {{"json", JobPath(job->id) + "/calibration.json"},
                   {"yaml", JobPath(job->id) + "/calibration.yaml"}}}});
    SetJson(response, 200, body);
  } catch (const std::exception& e) {
    SetProblem(response, 503, "calibration-unreadable", "Calibration unreadable",
               HideStateDirectory(e.what(), context.config->jobs.state_dir));
  }
}

void DeleteCalibration(const ApiContext& context, httplib::Response& response) {
  if (!context.calibration)
    return SetProblem(response, 404, "no-fusion", "No fused calibration",
                      "this daemon keeps no fused calibration");
  try {
    context.calibration->Reset();
  } catch (const std::exception& e) {
    return SetProblem(response, 507, "calibration-not-stored", "Calibration reset not stored",
                      HideStateDirectory(e.what(), context.config->jobs.state_dir));
  }
  response.status = 204;
}

// The capture camera's joint calibration over its newest jobs' tracks, now
// (it is also made after every calibration.joint_every jobs).
void SolveJointCalibration(const ApiContext& context, httplib::Response& response) {
  if (!context.calibration)
    return SetProblem(response, 404, "no-fusion", "No camera calibration",
                      "this daemon keeps no calibration across jobs");
  try {
    const std::optional<nlohmann::json> joint =
        context.calibration->SolveJoint([&context](const std::string& id) {
          return context.store->OutputDir(id) / service::kTracksFile;
        });
    if (!joint)
      return SetProblem(response, 409, "joint-calibration-running", "A joint calibration runs",
                        "a joint calibration of the camera is running; ask again when it ends");
    SetJson(response, 200, context.calibration->JointSnapshot());
  } catch (const std::exception& e) {
    SetProblem(response, 409, "nothing-to-calibrate", "Nothing to calibrate from",
               HideStateDirectory(e.what(), context.config->jobs.state_dir));
  }
}

void GetCamera(const ApiContext& context, httplib::Response& response) {
  if (!context.camera) {
    return SetProblem(response, 404, "no-capture", "No capture source",
                      "this daemon runs without a capture source");
  }
  SetJson(response, 200, context.camera->Describe());
}

void GetSnapshot(const ApiContext& context, const httplib::Request& request,
                 httplib::Response& response) {
  SnapshotQuery query;
  try {
    query = ParseSnapshotQuery(request.params);
  } catch (const RequestError& e) {
    return SetProblem(response, 400, "invalid-request", "Invalid snapshot query", e.what());
  }
  cv::Mat frame = context.camera ? context.camera->NewestFrame() : cv::Mat();
  if (frame.empty()) {
    response.set_header("Retry-After", "1");
    return SetProblem(response, 503, "no-frame", "No frame yet",
                      "the capture source has not delivered a frame");
  }
  if (query.width > 0 && query.width < frame.cols) {
    const int height = std::max(1, static_cast<int>(std::lround(static_cast<double>(frame.rows) *
                                                                query.width / frame.cols)));
    cv::Mat scaled;
    cv::resize(frame, scaled, cv::Size(query.width, height), 0, 0, cv::INTER_AREA);
    frame = scaled;
  }
  const std::vector<unsigned char> jpeg = EncodeJpeg(frame, 90);
  response.set_content(std::string(jpeg.begin(), jpeg.end()), "image/jpeg");
}

void GetReady(const ApiContext& context, httplib::Response& response) {
  std::vector<std::string> problems;
  if (!context.camera) {
    problems.push_back("no capture source");
  } else {
    const service::CameraHealth status = context.camera->Health();
    if (!status.streaming) {
      problems.push_back("capture is not streaming" +
                         (status.last_error.empty() ? "" : " (" + status.last_error + ")"));
    }
  }
  if (context.scheduler->Full()) problems.push_back("the job queue is full");
  // A burst and its result take megabytes: below this the next job fails.
  constexpr int64_t kMinFreeStateBytes = 16LL << 20;
  struct statvfs disk {};
  if (::statvfs(context.store->state_dir().c_str(), &disk) == 0) {
    const int64_t free_bytes =
        static_cast<int64_t>(disk.f_bavail) * static_cast<int64_t>(disk.f_frsize);
    if (free_bytes < kMinFreeStateBytes) {
      problems.push_back("the state directory is full (" + std::to_string(free_bytes >> 10) +
                         " KiB free); DELETE /api/v1/jobs/{id} frees space");
    }
  } else {
    problems.push_back("the state directory cannot be examined (" +
                       std::string(std::strerror(errno)) + ")");
  }
  if (problems.empty()) return SetJson(response, 200, {{"status", "ready"}});
  std::string detail;
  for (const std::string& p : problems) detail += (detail.empty() ? "" : "; ") + p;
  SetProblem(response, 503, "not-ready", "Not ready", detail);
}

void GetMetrics(const ApiContext& context, httplib::Response& response) {
  service::GaugeSnapshot gauges;
  if (context.camera) {
    const service::CameraHealth status = context.camera->Health();
    gauges.frames_captured = status.frames_captured;
    gauges.frames_dropped = status.frames_dropped;
    gauges.reconnects = status.reconnects;
    gauges.streaming = status.streaming;
    gauges.ring_fill = status.ring_fill;
  }
  gauges.queue_depth = context.scheduler->Depth();
  gauges.queue_capacity = context.scheduler->capacity();
  gauges.jobs_processing = context.scheduler->Running();
  response.set_content(context.metrics->Render(gauges), "text/plain; version=0.0.4");
}

const char* WwwContentType(const std::string& path) {
  static const std::pair<const char*, const char*> kTypes[] = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".json", "application/json"},
      {".txt", "text/plain; charset=utf-8"},
      {".LICENSE", "text/plain; charset=utf-8"}};
  for (const auto& [extension, type] : kTypes) {
    const std::string_view e(extension);
    if (path.size() >= e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0)
      return type;
  }
  return "application/octet-stream";
}

// The page's files (www/, compiled in). Same-origin only: the page talks to
// this dfsmd and nothing else, and is never framed.
void GetWwwFile(const httplib::Request& request, const std::string& path,
                httplib::Response& response) {
  for (const WwwFile& file : WwwFiles()) {
    if (file.path != path) continue;
    response.set_header("Content-Security-Policy",
                        "default-src 'self'; img-src 'self' blob: data:; style-src 'self'; "
                        "connect-src 'self'; frame-ancestors 'none'");
    response.set_header("X-Content-Type-Options", "nosniff");
    response.set_header("Cache-Control", "no-cache");
    return ServeStaticBytes(request, response, file.data, WwwContentType(path));
  }
  SetProblem(response, 404, "not-found", "No such page file",
             WwwFiles().empty() ? "this dfsmd was built without its web page (no www/)"
                                : "'" + path + "' is not a file of the web page");
}

// Server-Sent Events of job changes (the page's live job list): one
// "event: job" per job that appears or changes status, stage or progress, and
// {"id", "deleted": true} for one that goes. A stream holds a bulk worker, so
// at most kMaxEventClients stream at once and each ends after
// server.event_stream_s (EventSource reconnects by itself).
constexpr int kMaxEventClients = 4;
std::atomic<int> event_clients{0};

void StreamJobEvents(const ApiContext& context, httplib::Response& response) {
  const int limit = std::min(kMaxEventClients, context.config->server.threads / 2);
  if (event_clients.fetch_add(1) >= limit) {
    --event_clients;
    response.set_header("Retry-After", "5");
    return SetProblem(response, 503, "too-many-event-clients", "Too many event streams",
                      "at most " + std::to_string(limit) +
                          " clients follow /api/v1/events at once; poll /api/v1/jobs instead");
  }
  struct Seen {
    std::map<std::string, std::string> jobs;  // id -> status/stage/progress key
    std::chrono::steady_clock::time_point end;
    std::chrono::steady_clock::time_point sent;
    uint64_t changes = 0;  // the store's change count at the last look
    bool first = true;
  };
  auto seen = std::make_shared<Seen>();
  seen->end = std::chrono::steady_clock::now() +
              std::chrono::seconds(context.config->server.event_stream_s);
  response.set_header("Cache-Control", "no-store");
  response.set_chunked_content_provider(
      "text/event-stream",
      [context, seen](size_t, httplib::DataSink& sink) {
        if (!seen->first) {
          // A change goes out as it happens, at most every 100 ms (a job's
          // progress moves often); a quiet stream gets a keep-alive every 500 ms.
          const auto since = std::chrono::steady_clock::now() - seen->sent;
          if (since < std::chrono::milliseconds(100))
            std::this_thread::sleep_for(std::chrono::milliseconds(100) - since);
          seen->changes =
              context.store->WaitForChange(seen->changes, std::chrono::milliseconds(500));
        }
        seen->sent = std::chrono::steady_clock::now();
        if (std::chrono::steady_clock::now() >= seen->end || !sink.is_writable()) {
          sink.done();
          return true;
        }
        std::string events = seen->first ? "retry: 2000\n\n" : "";
        seen->first = false;
        std::map<std::string, std::string> now;
        for (const Job& job : context.store->List()) {
          // What the page shows changing; the job's JSON only when it did.
          const std::string key = std::string(JobStatusName(job.status)) + "/" + job.stage + "/" +
                                  std::to_string(service::JobProgress(job));
          const auto before = seen->jobs.find(job.id);
          if (before == seen->jobs.end() || before->second != key)
            events += "event: job\ndata: " + JobJson(job).dump() + "\n\n";
          now[job.id] = key;
        }
        for (const auto& [id, key] : seen->jobs) {
          if (!now.count(id))
            events += "event: job\ndata: " + nlohmann::json{{"id", id}, {"deleted", true}}.dump() +
                      "\n\n";
        }
        seen->jobs = std::move(now);
        if (events.empty()) events = ": keep-alive\n\n";  // also detects a gone client
        return sink.write(events.data(), events.size());
      },
      [](bool) { --event_clients; });
}

}  // namespace

std::vector<std::string> JobFileNames() {
  std::vector<std::string> names;
  for (const auto& entry : kJobFiles) names.emplace_back(entry[0]);
  return names;
}

const char* JobFileContentType(const std::string& file) {
  for (const auto& entry : kJobFiles) {
    if (file == entry[0]) return entry[1];
  }
  return nullptr;
}

const std::vector<ApiResource>& ApiResources() {
  static const std::vector<ApiResource> resources = {
      {"/", "GET, HEAD"},
      {"/healthz", "GET, HEAD"},
      {"/readyz", "GET, HEAD"},
      {"/metrics", "GET, HEAD"},
      {"/ui/{path}", "GET, HEAD"},
      {"/api/v1/events", "GET, HEAD"},
      {"/api/v1/openapi.json", "GET, HEAD"},
      {"/api/v1/camera", "GET, HEAD"},
      {"/api/v1/snapshot.jpg", "GET, HEAD"},
      {"/api/v1/calibration", "GET, HEAD, DELETE"},
      {"/api/v1/calibration/solve", "POST"},
      {"/api/v1/captures", "POST"},
      {"/api/v1/jobs", "GET, HEAD, POST"},
      {"/api/v1/jobs/{id}", "GET, HEAD, DELETE"},
      {"/api/v1/jobs/{id}/{file}", "GET, HEAD"},
  };
  return resources;
}

std::string AllowedMethods(const std::string& path) {
  // The resources' paths as patterns: {path} is the rest of the path, any
  // other {name} one segment.
  static const std::vector<std::pair<std::regex, std::string>> patterns = [] {
    std::vector<std::pair<std::regex, std::string>> list;
    for (const ApiResource& resource : ApiResources()) {
      std::string pattern;
      for (size_t i = 0; i < resource.path.size(); ++i) {
        if (resource.path[i] == '{') {
          const size_t close = resource.path.find('}', i);
          pattern += resource.path.compare(i, close - i + 1, "{path}") == 0 ? ".+" : "[^/]+";
          i = close;
        } else {
          pattern +=
              resource.path[i] == '.' ? std::string("\\.") : std::string(1, resource.path[i]);
        }
      }
      list.emplace_back(std::regex(pattern), resource.methods);
    }
    return list;
  }();
  for (const auto& [pattern, methods] : patterns) {
    if (std::regex_match(path, pattern)) return methods;
  }
  return "";
}

void RegisterRoutes(const ApiContext& context, HttpServer* http) {
  const ApiContext c = context;
  service::JobScheduler* scheduler = context.scheduler;
  service::Metrics* metrics = context.metrics;
  const auto queue_full = [scheduler, metrics] {
    if (!scheduler->Full()) return false;
    metrics->JobRejected();
    return true;
  };
  http->SetGuard(RequestGuard(context.config->server, AllowedMethods, queue_full,
                              context.config->jobs.retry_after_s));
  httplib::Server* server = http->server();
  // The guard already refused unauthenticated requests; this second check
  // covers requests that reach httplib without the gate (the fuzzers).
  BearerAuth(context.config->server.token).Install(server);
  const std::string id = "([^/]+)";
  server->Get("/healthz", [](const httplib::Request&, httplib::Response& response) {
    SetJson(response, 200, {{"status", "alive"}});
  });
  server->Get("/readyz", [c](const httplib::Request&, httplib::Response& r) { GetReady(c, r); });
  server->Get("/metrics", [c](const httplib::Request&, httplib::Response& r) { GetMetrics(c, r); });
  server->Get("/api/v1/openapi.json", [](const httplib::Request&, httplib::Response& response) {
    SetJson(response, 200, OpenApiDocument());
  });
  server->Get("/api/v1/camera",
              [c](const httplib::Request&, httplib::Response& r) { GetCamera(c, r); });
  server->Get("/api/v1/snapshot.jpg",
              [c](const httplib::Request& q, httplib::Response& r) { GetSnapshot(c, q, r); });
  server->Get(
      "/", [](const httplib::Request& q, httplib::Response& r) { GetWwwFile(q, "index.html", r); });
  server->Get("/ui/(.+)", [](const httplib::Request& q, httplib::Response& r) {
    GetWwwFile(q, q.matches[1], r);
  });
  server->Get("/api/v1/events",
              [c](const httplib::Request&, httplib::Response& r) { StreamJobEvents(c, r); });
  server->Get("/api/v1/calibration",
              [c](const httplib::Request&, httplib::Response& r) { GetCalibration(c, r); });
  // Routes that may carry a body read it through BoundedBody (request_body.h).
  const size_t max_body = static_cast<size_t>(context.config->server.max_body_bytes);
  server->Post("/api/v1/captures",
               BoundedBody(max_body, [c](const httplib::Request& q, httplib::Response& r) {
                 PostCapture(c, q, r);
               }));
  server->Post("/api/v1/jobs",
               [c](const httplib::Request& q, httplib::Response& r,
                   const httplib::ContentReader& reader) { PostJob(c, q, r, reader); });
  server->Get("/api/v1/jobs",
              [c](const httplib::Request& q, httplib::Response& r) { ListJobs(c, q, r); });
  server->Get("/api/v1/jobs/" + id,
              [c](const httplib::Request& q, httplib::Response& r) { GetJob(c, q, r); });
  server->Delete("/api/v1/jobs/" + id,
                 BoundedBody(max_body, [c](const httplib::Request& q, httplib::Response& r) {
                   DeleteJob(c, q, r);
                 }));
  server->Get("/api/v1/jobs/" + id + "/" + id,
              [c](const httplib::Request& q, httplib::Response& r) { GetJobFile(c, q, r); });
  server->Delete("/api/v1/calibration",
                 BoundedBody(max_body, [c](const httplib::Request&, httplib::Response& r) {
                   DeleteCalibration(c, r);
                 }));
  server->Post("/api/v1/calibration/solve",
               BoundedBody(max_body, [c](const httplib::Request&, httplib::Response& r) {
                 SolveJointCalibration(c, r);
               }));

  RegisterBodyCatchAlls(max_body, server);
  server->set_error_handler(
      [max_body](const httplib::Request& request, httplib::Response& response) {
        if (response.body.empty()) SetDefaultProblem(request, response, max_body);
      });
  server->set_exception_handler(
      [](const httplib::Request&, httplib::Response& response, std::exception_ptr error) {
        std::string what = "unknown error";
        try {
          if (error) std::rethrow_exception(error);
        } catch (const std::exception& e) {
          what = e.what();
        } catch (...) {
        }
        SetProblem(response, 500, "internal-error", "Internal error", what);
      });
  const std::string origin = context.config->server.cors_origin;
  server->set_post_routing_handler([origin](const httplib::Request&, httplib::Response& response) {
    // Job files, calibration, snapshots and metrics are what a token protects:
    // no browser or proxy cache keeps a copy. The page's own files say
    // no-cache (public, revalidated) themselves.
    if (!response.has_header("Cache-Control")) response.set_header("Cache-Control", "no-store");
    if (origin.empty()) return;
    response.set_header("Access-Control-Allow-Origin", origin);
    response.set_header("Access-Control-Expose-Headers", "Location, Retry-After, Link");
  });
  if (!origin.empty()) {
    server->Options(".*", [origin](const httplib::Request&, httplib::Response& response) {
      response.set_header("Access-Control-Allow-Methods", "GET, POST, DELETE, OPTIONS");
      response.set_header("Access-Control-Allow-Headers", "Authorization, Content-Type");
      response.set_header("Access-Control-Max-Age", "600");
      response.status = 204;
    });
  }
  // The gate's refusals never reach httplib's logger: counted here, so that
  // token guessing and cross-site attempts show in /metrics.
  http->SetRefusalObserver([metrics](int status) { metrics->HttpRequest(status); });
  server->set_logger([metrics](const httplib::Request&, const httplib::Response& response) {
    metrics->HttpRequest(response.status);
  });
}

}  // namespace dfsm::api
