#include "api/connection_gate.h"

#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace dfsm::api {
namespace {

// Bytes read and thrown away from a refused connection before it is closed:
// enough for the rest of a typical head and the start of a body.
constexpr size_t kDrainBytes = 1 << 20;

}  // namespace

void ConnectionGateOptions::Check() const {
  if (max_connections < 4) throw std::invalid_argument("max_connections must be at least 4");
  if (head_timeout.count() < 1) throw std::invalid_argument("head_timeout must be positive");
  if (keep_alive_timeout.count() < 1)
    throw std::invalid_argument("keep_alive_timeout must be positive");
  if (max_head_bytes < 256) throw std::invalid_argument("max_head_bytes must be at least 256");
}

ConnectionGate::ConnectionGate(ConnectionGateOptions options, Judge judge, Refuse refuse)
    : options_(options), judge_(std::move(judge)), refuse_(std::move(refuse)) {
  options_.Check();
}

ConnectionGate::~ConnectionGate() { Stop(); }

void ConnectionGate::Start() {
  if (thread_.joinable()) return;
  epoll_ = ::epoll_create1(EPOLL_CLOEXEC);
  wake_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (epoll_ < 0 || wake_ < 0)
    throw std::runtime_error(std::string("connection gate: ") + std::strerror(errno));
  epoll_event event{};
  event.events = EPOLLIN;
  event.data.fd = wake_;
  if (::epoll_ctl(epoll_, EPOLL_CTL_ADD, wake_, &event) != 0)
    throw std::runtime_error(std::string("connection gate: epoll_ctl: ") + std::strerror(errno));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = false;
  }
  thread_ = std::thread([this] { Run(); });
}

void ConnectionGate::Stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t ignored = ::write(wake_, &one, sizeof(one));
  thread_.join();
  for (auto& [socket, connection] : held_) {
    ::close(socket);
    --open_;
  }
  held_.clear();
  std::lock_guard<std::mutex> lock(mutex_);
  for (const Arrival& arrival : arrivals_) Close(arrival.socket);
  arrivals_.clear();
  ::close(epoll_);
  ::close(wake_);
  epoll_ = wake_ = -1;
}

void ConnectionGate::Admit(int socket) {
  ++open_;
  Enqueue({socket, {}, 0, true});
}

void ConnectionGate::Readmit(int socket, std::string bytes, int served) {
  Enqueue({socket, std::move(bytes), served, false});
}

void ConnectionGate::Linger(int socket) { Enqueue({socket, {}, 0, false, true}); }

void ConnectionGate::Enqueue(Arrival arrival) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (stopping_) {
    Close(arrival.socket);
    return;
  }
  arrivals_.push_back(std::move(arrival));
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t ignored = ::write(wake_, &one, sizeof(one));
}

void ConnectionGate::Close(int socket) {
  ::shutdown(socket, SHUT_RDWR);
  ::close(socket);
  --open_;
}

void ConnectionGate::Run() {
  std::vector<epoll_event> events(64);
  while (!stopping_) {
    // Wake for the nearest deadline (at least every second).
    Clock::time_point wake = Clock::now() + std::chrono::seconds(1);
    for (const auto& [socket, connection] : held_) wake = std::min(wake, connection.deadline);
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(wake - Clock::now());
    const int n = ::epoll_wait(epoll_, events.data(), static_cast<int>(events.size()),
                               static_cast<int>(std::max<int64_t>(0, wait.count()) + 1));
    for (int i = 0; i < n; ++i) {
      if (events[i].data.fd == wake_) {
        uint64_t count = 0;
        [[maybe_unused]] const ssize_t ignored = ::read(wake_, &count, sizeof(count));
        TakeArrivals();
      } else {
        OnReadable(events[i].data.fd);
      }
    }
    Expire(Clock::now());
  }
}

void ConnectionGate::TakeArrivals() {
  std::vector<Arrival> arrivals;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    arrivals.swap(arrivals_);
  }
  for (Arrival& arrival : arrivals) {
    // Over the limit: make room by closing the oldest connection waiting here
    // (idle or slow; a served one is never interrupted), else refuse.
    if (arrival.fresh && open_.load() > options_.max_connections) {
      if (held_.empty()) {
        Hold(arrival.socket, {}, 0, true);
        Answer(arrival.socket,
               refuse_(503, "too-many-connections",
                       "dfsmd serves at most server.max_connections (" +
                           std::to_string(options_.max_connections) +
                           ") connections at once and all are busy; retry shortly"));
        continue;
      }
      EvictOldest();
    }
    Hold(arrival.socket, std::move(arrival.bytes), arrival.served, arrival.fresh);
    if (arrival.linger) {
      Answer(arrival.socket, "");
      continue;
    }
    // Bytes of a pipelined request may already be here.
    if (!held_.at(arrival.socket).bytes.empty()) Examine(arrival.socket);
  }
}

void ConnectionGate::Hold(int socket, std::string bytes, int served, bool fresh) {
  Connection connection;
  connection.bytes = std::move(bytes);
  connection.served = served;
  connection.admitted = Clock::now();
  connection.started = fresh || !connection.bytes.empty();
  connection.deadline = connection.admitted +
                        (connection.started ? options_.head_timeout : options_.keep_alive_timeout);
  held_[socket] = std::move(connection);
  epoll_event event{};
  event.events = EPOLLIN | EPOLLRDHUP;
  event.data.fd = socket;
  if (::epoll_ctl(epoll_, EPOLL_CTL_ADD, socket, &event) != 0) Drop(socket);
}

void ConnectionGate::OnReadable(int socket) {
  const auto found = held_.find(socket);
  if (found == held_.end()) return;
  Connection& connection = found->second;
  if (connection.draining) {
    char sink[16384];
    const ssize_t n = ::recv(socket, sink, sizeof(sink), MSG_DONTWAIT);
    if (n > 0) connection.drained += static_cast<size_t>(n);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR) || connection.drained > kDrainBytes)
      Drop(socket);
    return;
  }
  const size_t room =
      options_.max_head_bytes + 1 - std::min(connection.bytes.size(), options_.max_head_bytes + 1);
  if (room == 0) return Examine(socket);
  const size_t before = connection.bytes.size();
  connection.bytes.resize(before + room);
  const ssize_t n = ::recv(socket, connection.bytes.data() + before, room, MSG_DONTWAIT);
  connection.bytes.resize(before + static_cast<size_t>(std::max<ssize_t>(n, 0)));
  if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
    // The client went away (or reset): nothing to answer.
    return Drop(socket);
  }
  if (n > 0 && !connection.started) {
    connection.started = true;
    connection.deadline = Clock::now() + options_.head_timeout;
  }
  Examine(socket);
}

void ConnectionGate::Examine(int socket) {
  Connection& connection = held_.at(socket);
  const size_t end = FindHeadEnd(connection.bytes);
  if (end == std::string::npos || end > options_.max_head_bytes) {
    if (connection.bytes.size() > options_.max_head_bytes || end != std::string::npos) {
      Answer(socket, refuse_(431, "head-too-large",
                             "the request line and headers exceed server.max_head_bytes (" +
                                 std::to_string(options_.max_head_bytes) + " bytes)"));
    }
    return;
  }
  ReadyRequest request;
  request.socket = socket;
  request.head_size = end;
  request.served = connection.served;
  try {
    request.head = ParseRequestHead(std::string_view(connection.bytes).substr(0, end));
  } catch (const HeadError& e) {
    return Answer(socket, refuse_(e.status(), e.slug(), e.what()));
  }
  request.bytes = std::move(connection.bytes);
  // The worker owns the socket from here on.
  ::epoll_ctl(epoll_, EPOLL_CTL_DEL, socket, nullptr);
  held_.erase(socket);
  HeadVerdict verdict = judge_(request);
  if (verdict.serve) return;
  Hold(socket, {}, request.served, true);
  Answer(socket, verdict.response);
}

void ConnectionGate::Answer(int socket, const std::string& response) {
  // The answer is small and the socket's send buffer empty: one non-blocking
  // send. Then half-close and drain, so that the client reads the answer
  // rather than a reset caused by the body it is still sending.
  if (!response.empty()) {
    [[maybe_unused]] const ssize_t sent =
        ::send(socket, response.data(), response.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  }
  ::shutdown(socket, SHUT_WR);
  Connection& connection = held_.at(socket);
  connection.draining = true;
  connection.bytes.clear();
  connection.deadline = Clock::now() + options_.linger;
}

void ConnectionGate::Expire(Clock::time_point now) {
  std::vector<int> expired;
  for (const auto& [socket, connection] : held_) {
    if (connection.deadline <= now) expired.push_back(socket);
  }
  for (int socket : expired) {
    Connection& connection = held_.at(socket);
    if (connection.draining || !connection.started) {
      Drop(socket);  // drained, or an idle keep-alive: close quietly
    } else {
      Answer(socket, refuse_(408, "request-timeout",
                             "the request head did not arrive within server.head_timeout_ms (" +
                                 std::to_string(options_.head_timeout.count()) + " ms)"));
    }
  }
}

void ConnectionGate::Drop(int socket) {
  ::epoll_ctl(epoll_, EPOLL_CTL_DEL, socket, nullptr);
  held_.erase(socket);
  Close(socket);
}

void ConnectionGate::EvictOldest() {
  auto oldest = held_.end();
  for (auto it = held_.begin(); it != held_.end(); ++it) {
    if (oldest == held_.end() || it->second.admitted < oldest->second.admitted) oldest = it;
  }
  if (oldest != held_.end()) Drop(oldest->first);
}

}  // namespace dfsm::api
