#include "api/openapi.h"

#include <string>

namespace dfsm::api {
namespace {

// ParseRollingShutter's forms (core/camera/rolling_shutter.h), as a pattern.
constexpr const char* kRollingShutterPattern = "^(global|estimate|0(\\.[0-9]+)?|1(\\.0+)?)$";

using nlohmann::json;

json Ref(const std::string& name) { return {{"$ref", "#/components/schemas/" + name}}; }

json Problem(const std::string& description) {
  return {{"description", description},
          {"content", {{"application/problem+json", {{"schema", Ref("Problem")}}}}}};
}

json JsonBody(const std::string& description, const json& schema) {
  return {{"description", description}, {"content", {{"application/json", {{"schema", schema}}}}}};
}

json Binary(const std::string& description, const std::string& type) {
  return {{"description", description},
          {"content", {{type, {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}};
}

json JobIdParameter() {
  return {{"name", "id"},
          {"in", "path"},
          {"required", true},
          {"schema", {{"type", "string"}, {"pattern", "^j[0-9]{13}-[0-9a-f]{4}$"}}}};
}

json QueryParameter(const std::string& name, const json& schema, const std::string& description) {
  return {{"name", name},
          {"in", "query"},
          {"required", false},
          {"schema", schema},
          {"description", description}};
}

json Accepted() {
  json response = JsonBody("Job accepted and queued", Ref("Accepted"));
  response["headers"] = {
      {"Location", {{"schema", {{"type", "string"}}}, {"description", "/api/v1/jobs/{id}"}}}};
  return response;
}

json QueueFull() {
  json response = Problem("Job queue full, or no burst available from capture");
  response["headers"] = {{"Retry-After", {{"schema", {{"type", "integer"}}}}}};
  return response;
}

json Schemas() {
  const json integer = {{"type", "integer"}};
  const json string = {{"type", "string"}};
  const json boolean = {{"type", "boolean"}};
  json options = {
      {"type", "object"},
      {"additionalProperties", false},
      {"properties",
       {{"frames", {{"type", "integer"}, {"minimum", 3}}},
        {"when", {{"type", "string"}, {"enum", {"last", "next"}}}},
        {"planes", {{"type", "integer"}, {"minimum", 2}, {"maximum", 1024}}},
        {"grid", {{"type", "integer"}, {"minimum", 0}}},
        {"init", {{"type", "string"}, {"enum", {"rank1", "naive"}}}},
        {"rolling_shutter",
         {{"type", "string"},
          {"pattern", kRollingShutterPattern},
          {"description", "global | estimate | readout in [0, 1] of the frame interval"}}},
        {"dense", boolean},
        {"keep_burst", boolean},
        {"calibration", {{"type", "string"}, {"enum", {"auto", "self"}}}}}}};
  json schemas;
  schemas["Problem"] = {
      {"type", "object"},
      {"properties",
       {{"type", string}, {"title", string}, {"status", integer}, {"detail", string}}},
      {"required", {"type", "title", "status", "detail"}}};
  schemas["CaptureRequest"] = options;
  schemas["Accepted"] = {{"type", "object"}, {"properties", {{"id", string}, {"status", string}}}};
  json job = {{"id", string},          {"origin", string},      {"status", string},
              {"stage", string},       {"error", string},       {"options", options},
              {"created_ms", integer}, {"started_ms", integer}, {"finished_ms", integer},
              {"attempts", integer},   {"has_burst", boolean},  {"bytes", integer}};
  job["status"]["enum"] = {"queued", "processing", "succeeded", "failed"};
  job["timings_ms"] = {{"type", "object"}, {"additionalProperties", {{"type", "number"}}}};
  job["input"] = {{"type", "object"}};
  job["progress"] = {{"type", "number"}, {"minimum", 0}, {"maximum", 1}};
  job["links"] = {{"type", "object"}};
  schemas["Job"] = {{"type", "object"}, {"properties", job}};
  json list = {{"jobs", {{"type", "array"}, {"items", Ref("Job")}}}};
  list["next"] = {{"type", "string"}, {"nullable", true}};
  schemas["JobList"] = {{"type", "object"}, {"properties", list}};
  json camera;
  for (const char* key : {"source", "device", "driver", "card", "format"}) camera[key] = string;
  for (const char* key : {"width", "height", "frames_captured", "frames_dropped", "reconnects",
                          "ring_fill", "ring_capacity", "last_frame_monotonic_ns"}) {
    camera[key] = integer;
  }
  camera["fps"] = {{"type", "number"}};
  camera["streaming"] = boolean;
  camera["last_error"] = {{"type", "string"}, {"nullable", true}};
  schemas["Camera"] = {{"type", "object"}, {"properties", camera}};
  json calibration = {{"job", string}, {"finished_ms", integer}};
  calibration["calibration"] = {{"type", "object"}};
  calibration["rms_reprojection_px"] = {{"type", "number"}};
  calibration["links"] = {{"type", "object"}};
  calibration["fused"] = {{"type", "object"}};
  schemas["Calibration"] = {{"type", "object"}, {"properties", calibration}};
  return schemas;
}

}  // namespace

nlohmann::json OpenApiDocument() {
  json paths;
  paths["/api/v1/captures"]["post"] = {
      {"summary", "Take a burst from the capture ring and queue a pipeline job"},
      {"requestBody",
       {{"required", false},
        {"content", {{"application/json", {{"schema", Ref("CaptureRequest")}}}}}}},
      {"responses",
       {{"202", Accepted()},
        {"400", Problem("Invalid request body")},
        {"503", QueueFull()},
        {"507", Problem("The burst cannot be stored (state directory full or unwritable)")}}}};
  paths["/api/v1/jobs"]["post"] = {
      {"summary", "Upload a tar of a dfsm-burst/1 directory and queue a pipeline job"},
      {"parameters",
       {QueryParameter("frames", {{"type", "integer"}}, "frames to use (0: all)"),
        QueryParameter("planes", {{"type", "integer"}}, "plane-sweep planes"),
        QueryParameter("grid", {{"type", "integer"}}, "feature grid cell, pixels"),
        QueryParameter("init", {{"type", "string"}, {"enum", {"rank1", "naive"}}}, ""),
        QueryParameter("rolling_shutter", {{"type", "string"}, {"pattern", kRollingShutterPattern}},
                       "global | estimate | readout in [0, 1] of the frame interval"),
        QueryParameter("dense", {{"type", "boolean"}}, ""),
        QueryParameter("keep_burst", {{"type", "boolean"}}, ""),
        QueryParameter("calibration", {{"type", "string"}, {"enum", {"auto", "self"}}},
                       "auto: the configured or fused calibration; self: this burst alone")}},
      {"requestBody",
       {{"required", true},
        {"content",
         {{"application/x-tar", {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}}},
      {"responses",
       {{"202", Accepted()},
        {"400", Problem("Invalid options or empty body")},
        {"413", Problem("Body larger than server.max_body_bytes")},
        {"415", Problem("Not a tar upload")},
        {"422", Problem("Not a valid ustar archive of a dfsm-burst/1 directory, or over a "
                        "[limits] key (entries, file size, frames, pixels)")},
        {"503", QueueFull()},
        {"507", Problem("The burst cannot be stored (state directory full or unwritable)")}}}};
  paths["/api/v1/jobs"]["get"] = {
      {"summary", "List jobs, newest first"},
      {"parameters",
       {QueryParameter("limit", {{"type", "integer"}, {"minimum", 1}, {"maximum", 1000}},
                       "page size (default 20)"),
        QueryParameter("after", {{"type", "string"}}, "job id: list older jobs (from `next`)"),
        QueryParameter("status", {{"type", "string"}}, "only jobs with this status")}},
      {"responses",
       {{"200", JsonBody("A page of jobs", Ref("JobList"))}, {"400", Problem("Invalid query")}}}};
  paths["/api/v1/jobs/{id}"]["parameters"] = {JobIdParameter()};
  paths["/api/v1/jobs/{id}"]["get"] = {
      {"summary", "A job's status, stage, timings and error"},
      {"responses", {{"200", JsonBody("The job", Ref("Job"))}, {"404", Problem("Unknown job")}}}};
  paths["/api/v1/jobs/{id}"]["delete"] = {
      {"summary", "Delete a queued or finished job and its files"},
      {"responses",
       {{"204", {{"description", "Deleted"}}},
        {"404", Problem("Unknown job")},
        {"409", Problem("The job is being processed")}}}};
  json file_parameter = {
      {"name", "file"},
      {"in", "path"},
      {"required", true},
      {"schema",
       {{"type", "string"},
        {"enum",
         {"result.json", "depth.tiff", "depth.png", "preview.png", "confidence.png", "points.ply",
          "sparse_points.ply", "calibration.json", "calibration.yaml", "burst.tar"}}}}};
  paths["/api/v1/jobs/{id}/{file}"]["get"] = {
      {"summary", "A job's input burst (burst.tar) or one of its outputs"},
      {"parameters", {JobIdParameter(), file_parameter}},
      {"responses",
       {{"200", Binary("The file (application/json, image/tiff, image/png, application/yaml, "
                       "application/octet-stream for PLY, application/x-tar)",
                       "application/octet-stream")},
        {"404", Problem("Unknown job or file, or not produced")},
        {"409", Problem("Job not finished")},
        {"410", Problem("Burst deleted (keep_burst false)")}}}};
  paths["/api/v1/calibration"]["get"] = {
      {"summary",
       "The camera's calibration: the newest successful job's (with its uncertainty and "
       "verdict) and the fusion of every job's estimate (fused, sigma, bursts, history)"},
      {"responses",
       {{"200", JsonBody("Calibration", Ref("Calibration"))},
        {"404", Problem("No job has succeeded yet")}}}};
  paths["/api/v1/calibration"]["delete"] = {
      {"summary", "Forget the fused calibration (a new camera, a new lens)"},
      {"responses",
       {{"204", {{"description", "Reset"}}}, {"507", Problem("The reset could not be stored")}}}};
  paths["/api/v1/camera"]["get"] = {
      {"summary", "State of the capture source"},
      {"responses", {{"200", JsonBody("Capture state", Ref("Camera"))}}}};
  paths["/api/v1/snapshot.jpg"]["get"] = {
      {"summary", "The newest captured frame"},
      {"responses", {{"200", Binary("JPEG", "image/jpeg")}, {"503", Problem("No frame yet")}}}};
  paths["/api/v1/events"]["get"] = {
      {"summary",
       "Server-Sent Events: 'event: job' with the job's JSON whenever a job appears or changes "
       "status, stage or progress ({id, deleted: true} when it goes); the stream ends after "
       "60 s (EventSource reconnects)"},
      {"responses",
       {{"200", {{"description", "text/event-stream"}}},
        {"503", Problem("Too many event streams: poll /api/v1/jobs")}}}};
  paths["/"]["get"] = {{"summary", "The web page (its files under /ui/)"},
                       {"responses", {{"200", {{"description", "text/html"}}}}}};
  paths["/api/v1/openapi.json"]["get"] = {
      {"summary", "This document"}, {"responses", {{"200", {{"description", "OpenAPI 3.0"}}}}}};
  paths["/healthz"]["get"] = {{"summary", "Liveness: the process answers"},
                              {"responses", {{"200", {{"description", "Alive"}}}}}};
  paths["/readyz"]["get"] = {
      {"summary", "Readiness: capture streams and the queue has room"},
      {"responses", {{"200", {{"description", "Ready"}}}, {"503", Problem("Not ready, and why")}}}};
  paths["/metrics"]["get"] = {
      {"summary", "Prometheus metrics"},
      {"responses", {{"200", {{"description", "text/plain; version=0.0.4"}}}}}};
  // Bearer authentication (bearer_auth.h): required wherever a token is
  // configured, which is always when dfsmd listens beyond loopback; the probes
  // and this document stay public.
  for (auto& [path, operations] : paths.items()) {
    const bool is_public =
        path == "/healthz" || path == "/readyz" || path == "/api/v1/openapi.json" || path == "/";
    for (auto& [method, operation] : operations.items()) {
      if (method == "parameters") continue;
      if (is_public) {
        operation["security"] = json::array();
      } else {
        operation["responses"]["401"] =
            Problem("Missing or wrong bearer token (WWW-Authenticate: Bearer realm=\"dfsmd\")");
      }
    }
  }
  return {{"openapi", "3.0.3"},
          {"info",
           {{"title", "dfsmd"},
            {"version", "1"},
            {"description",
             "Depth from small motion camera daemon: bursts in, depth maps and calibration out."}}},
          {"paths", paths},
          {"security", {{{"bearer", json::array()}}}},
          {"components",
           {{"schemas", Schemas()},
            {"securitySchemes",
             {{"bearer",
               {{"type", "http"},
                {"scheme", "bearer"},
                {"description",
                 "server.token_file or the systemd credential dfsmd-token; required when "
                 "server.listen is not loopback"}}}}}}}};
}

}  // namespace dfsm::api
