// The HTTP listener: cpp-httplib parses and routes requests, and dfsmd's
// connection gate (connection_gate.h) stands in front of it.
//
// httplib accepts (bind before listen, so readiness is only reported once the
// port is ours; no SO_REUSEPORT, so a second daemon on the port fails instead
// of sharing it). Each accepted socket goes to the gate, not to an httplib
// worker; the gate hands complete heads that the RequestGuard accepts to one
// of two worker pools (request_guard.h: control and bulk lanes), and a worker
// serves one request through httplib's own request processing, then gives a
// kept-alive connection back to the gate.
#pragma once

#include <httplib.h>

#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "api/connection_gate.h"
#include "api/request_guard.h"
#include "daemon/service/config.h"

namespace dfsm::api {

class HttpServer {
 public:
  explicit HttpServer(const service::ServerConfig& config);
  ~HttpServer();  // Stop()
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  httplib::Server* server();
  const service::ServerConfig& config() const { return config_; }

  // Every request head passes `guard` before it is served. Call before Start().
  void SetGuard(RequestGuard guard) { guard_.emplace(std::move(guard)); }
  // Told the status of every request the gate refuses itself (the guard's
  // 401, 403, 421, ... and the gate's 400, 408, 431, 503), which httplib never
  // sees. Any thread. Call before Start().
  void SetRefusalObserver(std::function<void(int status)> observer) {
    refusal_observer_ = std::move(observer);
  }
  // The gate's decision on a complete head: nullopt to serve it (in *lane), or
  // the complete HTTP response that refuses it. For the fuzzers, too.
  std::optional<std::string> Judge(const RequestHead& head, Lane* lane) const;

  // Binds the configured address; returns the port (the chosen one when the
  // configured port is 0). Throws std::runtime_error naming address and cause.
  int Bind();
  // Serves on threads of its own. Requires Bind().
  void Start();
  // Closes the listening socket, then every waiting connection, and joins
  // the workers (which finish the requests they are serving).
  void Stop();

  // Whether a request to /healthz through the listening port is answered
  // within `timeout` (the watchdog's probe: the server is not starved).
  bool Probe(std::chrono::milliseconds timeout) const;

 private:
  class Listener;

  HeadVerdict Dispatch(ReadyRequest& request);
  void Serve(ReadyRequest request);

  const service::ServerConfig config_;
  std::unique_ptr<Listener> listener_;
  std::optional<RequestGuard> guard_;
  std::function<void(int)> refusal_observer_;
  std::unique_ptr<ConnectionGate> gate_;
  std::unique_ptr<httplib::ThreadPool> control_;
  std::unique_ptr<httplib::ThreadPool> bulk_;
  std::thread thread_;
  std::atomic<bool> listening_ended_{false};  // listen_after_bind returned
  std::atomic<bool> stopping_{false};
  bool bound_ = false;
  int port_ = 0;
};

// The head as the gate hands it to httplib once judged: Range applied as
// api/byte_range.h says (one byte range as kGateRangeField, anything else
// dropped) and written anew with CR LF line ends, so that httplib parses
// exactly the head the gate judged. For the fuzzers, too.
std::string HandedOnHead(RequestHead head);

// A complete HTTP/1.1 response carrying a problem+json body, that closes the
// connection: what the gate answers without a worker.
std::string ProblemResponse(int status, const std::string& slug, const std::string& detail,
                            const std::vector<std::pair<std::string, std::string>>& headers);

}  // namespace dfsm::api
