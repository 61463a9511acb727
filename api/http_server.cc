#include "api/http_server.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <cerrno>
#include <chrono>
#include <cstring>

namespace dfsm::api {

HttpServer::HttpServer(const service::ServerConfig& config) : config_(config) {
  const size_t threads = static_cast<size_t>(config.threads);
  server_.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  server_.set_payload_max_length(static_cast<size_t>(config.max_body_bytes));
  server_.set_socket_options([](int socket) {
    // SO_REUSEADDR (restart while old connections sit in TIME_WAIT) but not
    // httplib's default SO_REUSEPORT, which lets two daemons share the port.
    int yes = 1;
    ::setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  server_.set_tcp_nodelay(true);
  server_.set_keep_alive_timeout(5);
  server_.set_read_timeout(30);  // large uploads on slow links
  server_.set_write_timeout(30);
}

HttpServer::~HttpServer() { Stop(); }

int HttpServer::Bind() {
  errno = 0;
  int port = config_.port;
  if (port == 0) {
    port = server_.bind_to_any_port(config_.listen);
    if (port < 0) port = 0;
  } else if (!server_.bind_to_port(config_.listen, port)) {
    port = 0;
  }
  if (port == 0) {
    const std::string cause = errno ? std::strerror(errno) : "address not usable";
    throw std::runtime_error("cannot listen on " + config_.listen + ":" +
                             std::to_string(config_.port) + ": " + cause);
  }
  bound_ = true;
  return port;
}

void HttpServer::Start() {
  if (!bound_ || thread_.joinable()) return;
  listening_ended_ = false;
  thread_ = std::thread([this] {
    server_.listen_after_bind();
    listening_ended_ = true;
  });
}

void HttpServer::Stop() {
  if (!thread_.joinable()) return;
  // httplib's stop() acts only once listen_after_bind has marked the server
  // running: called earlier it does nothing, the loop starts afterwards and
  // the join waits forever. So wait for the loop (or for its early end).
  while (!server_.is_running() && !listening_ended_)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  server_.stop();
  thread_.join();
}

}  // namespace dfsm::api
