// The HTTP listener: a cpp-httplib server configured against its pitfalls
// (see PITFALLS.md): no SO_REUSEPORT (a second daemon on the port must fail,
// not share it), a payload limit, a fixed worker pool, bind before listen so
// that readiness is only reported once the port is ours, stop() + join.
#pragma once

#include <httplib.h>

#include <atomic>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include "daemon/service/config.h"

namespace dfsm::api {

class HttpServer {
 public:
  explicit HttpServer(const service::ServerConfig& config);
  ~HttpServer();  // Stop()
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  httplib::Server* server() { return &server_; }

  // Binds the configured address; returns the port (the chosen one when the
  // configured port is 0). Throws std::runtime_error naming address and cause.
  int Bind();
  // Serves on a thread of its own. Requires Bind().
  void Start();
  // Closes the listening socket and joins the serving thread (which waits for
  // the worker pool to drain its connections).
  void Stop();

 private:
  const service::ServerConfig config_;
  httplib::Server server_;
  std::thread thread_;
  std::atomic<bool> listening_ended_{false};  // listen_after_bind returned
  bool bound_ = false;
};

}  // namespace dfsm::api
