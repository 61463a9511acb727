// What dfsmd decides from a request's head alone, before any worker thread,
// route handler or body byte is spent on it (connection_gate.h calls it):
//
//   421  the Host is not one of server.allowed_hosts: a page on another site
//        that rebinds its DNS name to 127.0.0.1 (DNS rebinding) sends its own
//        name, never one of ours. A literal IP address cannot be rebound and
//        is always accepted;
//   403  a state-changing request (POST, DELETE) from a browser page of
//        another origin (Origin neither this Host nor server.cors_origin);
//   401  no or the wrong bearer token (bearer_auth.h);
//   405  a method the resource does not have (PUT, PATCH), with Allow;
//   501  a method dfsmd does not know (TRACE, CONNECT, ...);
//   413  a declared body over server.max_body_bytes;
//   415  a POST whose Content-Type is missing or not the route's: a browser
//        sends text/plain or a form type without a CORS preflight, never
//        application/json or application/x-tar;
//   503  a capture or upload while the job queue is full, with Retry-After:
//        answered here, so that no worker waits for a body or a burst that
//        would be refused anyway.
//
// Everything else is served, in one of two lanes: short reads (probes,
// status, lists) on the control workers, everything that carries or returns
// bulk data (uploads, captures, job files, snapshots) on the bulk workers, so
// that /healthz answers while every bulk worker is busy.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "api/bearer_auth.h"
#include "api/request_head.h"
#include "daemon/service/config.h"

namespace dfsm::api {

enum class Lane { kControl, kBulk };

struct Refusal {
  int status = 0;
  std::string slug;
  std::string detail;
  std::vector<std::pair<std::string, std::string>> headers;  // e.g. WWW-Authenticate, Allow
};

class RequestGuard {
 public:
  // `allowed_methods(path)`: the methods the API has on `path` ("GET, DELETE"),
  // "" for a path it does not have. `queue_full()`: whether the job queue
  // takes no job now (null: never full); its 503 says retry after
  // `retry_after_s`.
  RequestGuard(const service::ServerConfig& config,
               std::function<std::string(const std::string& path)> allowed_methods,
               std::function<bool()> queue_full = nullptr, int retry_after_s = 5);

  // nullopt: serve the request in *lane.
  std::optional<Refusal> Check(const RequestHead& head, Lane* lane) const;

  // Headers every answer carries (CORS, when server.cors_origin is set).
  const std::vector<std::pair<std::string, std::string>>& common_headers() const {
    return common_headers_;
  }

  // The host names accepted in Host (lower-case), as configured or by default:
  // "localhost", this machine's host name (and <name>.local), and the listen
  // address when it is a name.
  const std::vector<std::string>& allowed_hosts() const { return allowed_hosts_; }

 private:
  bool HostAllowed(const std::string& host_field) const;
  bool OriginAllowed(const std::string& origin, const std::string& host_field) const;

  const BearerAuth auth_;
  const std::string cors_origin_;
  const uint64_t max_body_bytes_;
  const std::function<std::string(const std::string&)> allowed_methods_;
  const std::function<bool()> queue_full_;
  const int retry_after_s_;
  std::vector<std::string> allowed_hosts_;
  bool any_host_ = false;
  std::vector<std::pair<std::string, std::string>> common_headers_;
};

// The host names of a comma-separated server.allowed_hosts value ("" gives
// the defaults above; "*" accepts any Host).
std::vector<std::string> AllowedHosts(const service::ServerConfig& config);

}  // namespace dfsm::api
