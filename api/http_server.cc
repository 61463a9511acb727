#include "api/http_server.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "api/byte_range.h"
#include "api/gate_stream.h"
#include "api/problem.h"
#include "daemon/log/log.h"

namespace dfsm::api {
namespace {

// httplib runs each accepted socket's task on its task queue; this one runs it
// at once on the accepting thread, where Listener hands the socket to the
// gate (a few microseconds).
class InlineQueue final : public httplib::TaskQueue {
 public:
  void enqueue(std::function<void()> fn) override { fn(); }
  void shutdown() override {}
};

std::string PeerAddress(int socket) {
  std::string ip;
  int port = 0;
  SocketAddress(socket, true, ip, port);
  return ip.empty() ? "?" : ip;
}

// Requests served on one connection before it is closed (httplib's default).
constexpr int kKeepAliveMaxCount = 100;

// Range never reaches httplib (api/byte_range.h says why): one byte range of
// a GET or HEAD travels on as kGateRangeField, anything else is dropped and
// the resource is served whole. Without a validator (dfsmd sends no ETag or
// Last-Modified) an If-Range cannot match, so it, too, means the whole.
void GateRange(RequestHead& head) {
  std::optional<ByteRange> range;
  if (const std::string* value = head.Field("Range");
      value && (head.method == "GET" || head.method == "HEAD") && !head.Field("If-Range"))
    range = ParseSingleByteRange(*value);
  if (head.RemoveFields("Range") != 1) range.reset();
  head.RemoveFields(kGateRangeField);
  if (range) head.fields.emplace_back(kGateRangeField, FormatRangeSpec(*range));
}

}  // namespace

// httplib parses the head again, by rules of its own: a line ended by a bare
// LF is no line end to it, so after a head that the gate saw end in "\n\n"
// it went on reading the body as header fields (a Range among them, which the
// gate never saw). It is handed the head the gate judged, written anew with
// CR LF line ends; the bytes after it pass unchanged.
std::string HandedOnHead(RequestHead head) {
  GateRange(head);
  return head.Serialize();
}

// httplib's server with its per-connection processing replaced: the socket
// goes to the gate; requests come back through ServeOne.
class HttpServer::Listener final : public httplib::Server {
 public:
  explicit Listener(HttpServer* owner) : owner_(owner) {}

  bool ServeOne(httplib::Stream& stream, bool close_connection, bool& connection_closed) {
    return process_request(stream, close_connection, connection_closed, nullptr);
  }

  // httplib listens with a backlog of 5: a burst of connections (a page
  // loading, a client retrying) overflows it and each dropped SYN costs the
  // client a 1 s retransmission. Listening again on the bound socket only
  // widens the queue.
  void WidenBacklog() { ::listen(svr_sock_, SOMAXCONN); }

 private:
  bool process_and_close_socket(socket_t socket) override {
    owner_->gate_->Admit(socket);
    return true;
  }

  HttpServer* owner_;
};

std::string ProblemResponse(int status, const std::string& slug, const std::string& detail,
                            const std::vector<std::pair<std::string, std::string>>& headers) {
  const std::string body = ProblemBody(status, slug, StatusTitle(status), detail);
  std::string response = "HTTP/1.1 " + std::to_string(status) + " " + StatusTitle(status) +
                         "\r\nContent-Type: " + kProblemContentType +
                         "\r\nContent-Length: " + std::to_string(body.size()) +
                         "\r\nConnection: close\r\n";
  for (const auto& [name, value] : headers) response += name + ": " + value + "\r\n";
  return response + "\r\n" + body;
}

HttpServer::HttpServer(const service::ServerConfig& config)
    : config_(config), listener_(std::make_unique<Listener>(this)) {
  listener_->new_task_queue = [] { return new InlineQueue; };
  listener_->set_payload_max_length(static_cast<size_t>(config.max_body_bytes));
  listener_->set_socket_options([](int socket) {
    // SO_REUSEADDR (restart while old connections sit in TIME_WAIT) but not
    // httplib's default SO_REUSEPORT, which lets two daemons share the port.
    int yes = 1;
    ::setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  listener_->set_tcp_nodelay(true);
  listener_->set_read_timeout(30);  // large uploads on slow links
  listener_->set_write_timeout(30);

  ConnectionGateOptions gate;
  gate.max_connections = config.max_connections;
  gate.head_timeout = std::chrono::milliseconds(config.head_timeout_ms);
  gate.keep_alive_timeout = std::chrono::seconds(5);
  gate.max_head_bytes = static_cast<size_t>(config.max_head_bytes);
  gate_ = std::make_unique<ConnectionGate>(
      gate, [this](ReadyRequest& request) { return Dispatch(request); },
      [this](int status, const std::string& slug, const std::string& detail) {
        if (refusal_observer_) refusal_observer_(status);
        log::WriteLimited(log::Priority::kNotice, "refused connection",
                          "refused a connection: " + std::to_string(status) + " " + detail);
        return ProblemResponse(
            status, slug, detail,
            guard_ ? guard_->common_headers() : std::vector<std::pair<std::string, std::string>>{});
      });
}

HttpServer::~HttpServer() { Stop(); }

httplib::Server* HttpServer::server() { return listener_.get(); }

std::optional<std::string> HttpServer::Judge(const RequestHead& head, Lane* lane) const {
  *lane = Lane::kBulk;
  if (!guard_) return std::nullopt;
  std::optional<Refusal> refusal = guard_->Check(head, lane);
  if (!refusal) return std::nullopt;
  std::vector<std::pair<std::string, std::string>> headers = guard_->common_headers();
  headers.insert(headers.end(), refusal->headers.begin(), refusal->headers.end());
  return ProblemResponse(refusal->status, refusal->slug, refusal->detail, headers);
}

HeadVerdict HttpServer::Dispatch(ReadyRequest& request) {
  Lane lane = Lane::kBulk;
  if (std::optional<std::string> refusal = Judge(request.head, &lane)) {
    // "HTTP/1.1 421 Misdirected request": the status line names the refusal.
    const std::string status_line = refusal->substr(9, refusal->find('\r') - 9);
    if (refusal_observer_) refusal_observer_(std::stoi(status_line.substr(0, 3)));
    log::WriteLimited(log::Priority::kNotice, "refused request",
                      "refused " + request.head.method + " " + request.head.path.substr(0, 200) +
                          " from " + PeerAddress(request.socket) + ": " + status_line);
    return {false, std::move(*refusal)};
  }
  const std::string head = HandedOnHead(request.head);
  request.bytes = head + request.bytes.substr(request.head_size);
  request.head_size = head.size();
  httplib::ThreadPool* pool = lane == Lane::kControl ? control_.get() : bulk_.get();
  // std::function needs a copyable callable: the request travels by pointer.
  auto owned = std::make_shared<ReadyRequest>(std::move(request));
  pool->enqueue([this, owned] { Serve(std::move(*owned)); });
  return {true, {}};
}

void HttpServer::Serve(ReadyRequest request) {
  ReadPace pace;
  pace.grace = std::chrono::milliseconds(config_.body_grace_ms);
  pace.min_bytes_per_s = static_cast<uint64_t>(config_.min_body_rate);
  GateStream stream(request.socket, std::move(request.bytes), 0, std::chrono::seconds(30),
                    std::chrono::seconds(30), static_cast<size_t>(config_.max_head_bytes), pace);
  const bool close =
      request.head.WantsClose() || request.served + 1 >= kKeepAliveMaxCount || stopping_.load();
  bool connection_closed = false;
  const bool ok = listener_->ServeOne(stream, close, connection_closed);
  // A handler may answer without reading the body (an upload refused before
  // it): the rest of the body is not a next request, so the connection ends.
  // A chunked body's end is not known here: such connections end too.
  const bool body_left =
      request.head.chunked ||
      stream.bytes_read() < request.head_size + request.head.content_length.value_or(0);
  if (body_left) return gate_->Linger(request.socket);
  if (!ok || close || connection_closed) return gate_->Close(request.socket);
  gate_->Readmit(request.socket, stream.TakeUnread(), request.served + 1);
}

int HttpServer::Bind() {
  errno = 0;
  int port = config_.port;
  if (port == 0) {
    port = listener_->bind_to_any_port(config_.listen);
    if (port < 0) port = 0;
  } else if (!listener_->bind_to_port(config_.listen, port)) {
    port = 0;
  }
  if (port == 0) {
    const std::string cause = errno ? std::strerror(errno) : "address not usable";
    throw std::runtime_error("cannot listen on " + config_.listen + ":" +
                             std::to_string(config_.port) + ": " + cause);
  }
  listener_->WidenBacklog();
  bound_ = true;
  port_ = port;
  return port;
}

void HttpServer::Start() {
  if (!bound_ || thread_.joinable()) return;
  control_ = std::make_unique<httplib::ThreadPool>(static_cast<size_t>(config_.control_threads));
  bulk_ = std::make_unique<httplib::ThreadPool>(static_cast<size_t>(config_.threads));
  gate_->Start();
  listening_ended_ = false;
  stopping_ = false;
  thread_ = std::thread([this] {
    listener_->listen_after_bind();
    listening_ended_ = true;
  });
}

void HttpServer::Stop() {
  if (!thread_.joinable()) return;
  stopping_ = true;
  // httplib's stop() acts only once listen_after_bind has marked the server
  // running: called earlier it does nothing, the loop starts afterwards and
  // the join waits forever. So wait for the loop (or for its early end).
  while (!listener_->is_running() && !listening_ended_)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  listener_->stop();
  thread_.join();
  gate_->Stop();
  control_->shutdown();
  bulk_->shutdown();
}

bool HttpServer::Probe(std::chrono::milliseconds timeout) const {
  // The listen address itself, or loopback for a wildcard address.
  std::string host = config_.listen;
  if (host == "0.0.0.0" || host.empty()) host = "127.0.0.1";
  if (host == "::") host = "::1";
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (::getaddrinfo(host.c_str(), std::to_string(port_).c_str(), &hints, &found) != 0) return false;
  const int socket = ::socket(found->ai_family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  bool answered = false;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  auto remaining = [&] {
    return static_cast<int>(std::max<int64_t>(
        0, std::chrono::duration_cast<std::chrono::milliseconds>(deadline -
                                                                 std::chrono::steady_clock::now())
               .count()));
  };
  if (socket >= 0) {
    char address[INET6_ADDRSTRLEN] = {};
    const bool v6 = found->ai_family == AF_INET6;
    ::inet_ntop(
        found->ai_family,
        v6 ? static_cast<const void*>(&reinterpret_cast<sockaddr_in6*>(found->ai_addr)->sin6_addr)
           : &reinterpret_cast<sockaddr_in*>(found->ai_addr)->sin_addr,
        address, sizeof(address));
    const std::string request = "GET /healthz HTTP/1.1\r\nHost: " +
                                (v6 ? "[" + std::string(address) + "]" : std::string(address)) +
                                "\r\nConnection: close\r\n\r\n";
    pollfd fd{socket, POLLOUT, 0};
    if ((::connect(socket, found->ai_addr, found->ai_addrlen) == 0 || errno == EINPROGRESS) &&
        ::poll(&fd, 1, remaining()) == 1 &&
        ::send(socket, request.data(), request.size(), MSG_NOSIGNAL) ==
            static_cast<ssize_t>(request.size())) {
      std::string reply;
      char buffer[256];
      fd.events = POLLIN;
      while (reply.size() < 12 && ::poll(&fd, 1, remaining()) == 1) {
        const ssize_t n = ::recv(socket, buffer, sizeof(buffer), 0);
        if (n <= 0) break;
        reply.append(buffer, static_cast<size_t>(n));
      }
      answered = reply.rfind("HTTP/1.1 200", 0) == 0;
    }
    ::close(socket);
  }
  ::freeaddrinfo(found);
  return answered;
}

}  // namespace dfsm::api
