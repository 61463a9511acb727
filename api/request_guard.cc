#include "api/request_guard.h"

#include <arpa/inet.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <sstream>

namespace dfsm::api {
namespace {

bool IsIpLiteral(const std::string& host) {
  unsigned char buffer[sizeof(in6_addr)];
  return ::inet_pton(AF_INET, host.c_str(), buffer) == 1 ||
         ::inet_pton(AF_INET6, host.c_str(), buffer) == 1;
}

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

// The media type of a Content-Type value, without parameters, lower-case.
std::string MediaType(const std::string* content_type) {
  if (!content_type) return "";
  std::string type = Lower(content_type->substr(0, content_type->find(';')));
  while (!type.empty() && (type.back() == ' ' || type.back() == '\t')) type.pop_back();
  return type;
}

// The media types a POST route takes; empty for a path without POST.
std::vector<std::string> PostMediaTypes(const std::string& path) {
  if (path == "/api/v1/captures") return {"application/json"};
  if (path == "/api/v1/jobs") return {"application/x-tar", "application/octet-stream"};
  return {};
}

bool IsBulkRead(const std::string& path) {
  // Job files (/api/v1/jobs/<id>/<file>) and snapshots return megabytes.
  static const std::string jobs = "/api/v1/jobs/";
  if (path.rfind(jobs, 0) == 0 && path.find('/', jobs.size()) != std::string::npos) return true;
  // An event stream holds its worker for a minute.
  return path == "/api/v1/snapshot.jpg" || path == "/api/v1/events";
}

}  // namespace

std::vector<std::string> AllowedHosts(const service::ServerConfig& config) {
  std::vector<std::string> hosts;
  std::stringstream list(config.allowed_hosts);
  for (std::string item; std::getline(list, item, ',');) {
    item.erase(std::remove_if(item.begin(), item.end(), [](char c) { return c == ' '; }),
               item.end());
    if (!item.empty()) hosts.push_back(Lower(item));
  }
  if (!hosts.empty()) return hosts;
  hosts = {"localhost"};
  char name[256] = {};
  if (::gethostname(name, sizeof(name) - 1) == 0 && name[0] != '\0') {
    hosts.push_back(Lower(name));
    hosts.push_back(Lower(name) + ".local");
  }
  if (!IsIpLiteral(config.listen)) hosts.push_back(Lower(config.listen));
  return hosts;
}

RequestGuard::RequestGuard(const service::ServerConfig& config,
                           std::function<std::string(const std::string&)> allowed_methods,
                           std::function<bool()> queue_full, int retry_after_s)
    : auth_(config.token),
      cors_origin_(config.cors_origin),
      max_body_bytes_(static_cast<uint64_t>(config.max_body_bytes)),
      allowed_methods_(std::move(allowed_methods)),
      queue_full_(std::move(queue_full)),
      retry_after_s_(retry_after_s),
      allowed_hosts_(AllowedHosts(config)) {
  any_host_ = std::find(allowed_hosts_.begin(), allowed_hosts_.end(), "*") != allowed_hosts_.end();
  if (!cors_origin_.empty()) {
    common_headers_.emplace_back("Access-Control-Allow-Origin", cors_origin_);
    common_headers_.emplace_back("Access-Control-Expose-Headers", "Location, Retry-After, Link");
  }
}

bool RequestGuard::HostAllowed(const std::string& host_field) const {
  if (any_host_) return true;
  const std::string host = HostName(host_field);
  // A literal address names the machine itself: no DNS name to rebind.
  if (IsIpLiteral(host)) return true;
  if (host.size() > 10 && host.compare(host.size() - 10, 10, ".localhost") == 0) return true;
  return std::find(allowed_hosts_.begin(), allowed_hosts_.end(), host) != allowed_hosts_.end();
}

bool RequestGuard::OriginAllowed(const std::string& origin, const std::string& host_field) const {
  if (!cors_origin_.empty() && origin == cors_origin_) return true;
  // Same origin: a page dfsmd served itself ("http://<Host>").
  const size_t scheme = origin.find("://");
  if (scheme == std::string::npos) return false;  // "null" (sandboxed, file://) among others
  return Lower(origin.substr(scheme + 3)) == Lower(host_field);
}

std::optional<Refusal> RequestGuard::Check(const RequestHead& head, Lane* lane) const {
  *lane = Lane::kControl;
  const std::string* host = head.Field("Host");
  if (host && !HostAllowed(*host)) {
    std::string names;
    for (const std::string& name : allowed_hosts_) names += (names.empty() ? "" : ", ") + name;
    return Refusal{421,
                   "misdirected-request",
                   "Host '" + HostName(*host) +
                       "' is not this dfsmd's: use an IP address or one of server.allowed_hosts (" +
                       names + ")",
                   {}};
  }
  const std::string& method = head.method;
  const bool safe = method == "GET" || method == "HEAD" || method == "OPTIONS";
  if (const std::string* origin = head.Field("Origin"); origin && !safe) {
    if (!OriginAllowed(*origin, host ? *host : "")) {
      return Refusal{403,
                     "cross-origin-refused",
                     method + " from a page of origin '" + origin->substr(0, 100) +
                         "' is refused: only pages of this dfsmd or of server.cors_origin may "
                         "change its state",
                     {}};
    }
  }
  const std::string* authorization = head.Field("Authorization");
  if (const auto failure =
          auth_.Refusal(method, head.path, authorization ? *authorization : std::string())) {
    return Refusal{
        401, "unauthorized", failure->detail, {{"WWW-Authenticate", failure->challenge}}};
  }
  if (method != "GET" && method != "HEAD" && method != "OPTIONS" && method != "POST" &&
      method != "DELETE") {
    const std::string allowed = allowed_methods_ ? allowed_methods_(head.path) : "";
    if ((method == "PUT" || method == "PATCH") && !allowed.empty()) {
      return Refusal{405,
                     "method-not-allowed",
                     method + " is not supported on " + head.path + "; it allows " + allowed,
                     {{"Allow", allowed}}};
    }
    if (method != "PUT" && method != "PATCH") {
      return Refusal{501,
                     "method-not-implemented",
                     "dfsmd does not implement the method " + method.substr(0, 40),
                     {}};
    }
  }
  if (head.content_length.value_or(0) > max_body_bytes_) {
    return Refusal{413,
                   "body-too-large",
                   "the body (" + std::to_string(*head.content_length) +
                       " bytes) exceeds server.max_body_bytes (" + std::to_string(max_body_bytes_) +
                       " bytes)",
                   {}};
  }
  if (method == "POST") {
    const std::vector<std::string> types = PostMediaTypes(head.path);
    const std::string type = MediaType(head.Field("Content-Type"));
    if (!types.empty() && std::find(types.begin(), types.end(), type) == types.end()) {
      std::string wanted;
      for (const std::string& t : types) wanted += (wanted.empty() ? "" : " or ") + t;
      return Refusal{415,
                     "unsupported-media-type",
                     "POST " + head.path + " needs Content-Type " + wanted +
                         (type.empty() ? " (none was sent)" : ", not '" + type.substr(0, 80) + "'"),
                     {}};
    }
    if (!types.empty() && queue_full_ && queue_full_()) {
      const std::string retry = std::to_string(retry_after_s_);
      return Refusal{503,
                     "queue-full",
                     "the job queue is full; retry after " + retry + " s",
                     {{"Retry-After", retry}}};
    }
  }
  if (!safe || head.HasBody() || IsBulkRead(head.path)) *lane = Lane::kBulk;
  return std::nullopt;
}

}  // namespace dfsm::api
