#include "api/gate_stream.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace dfsm::api {
namespace {

bool WaitFor(int socket, short events, std::chrono::milliseconds timeout) {
  pollfd fd{socket, events, 0};
  for (;;) {
    const int n = ::poll(&fd, 1, static_cast<int>(timeout.count()));
    if (n < 0 && errno == EINTR) continue;
    return n > 0 && (fd.revents & (events | POLLHUP | POLLERR));
  }
}

}  // namespace

void SocketAddress(int socket, bool peer, std::string& ip, int& port) {
  sockaddr_storage address{};
  socklen_t length = sizeof(address);
  char text[INET6_ADDRSTRLEN] = "";
  port = 0;
  const int status = peer ? ::getpeername(socket, reinterpret_cast<sockaddr*>(&address), &length)
                          : ::getsockname(socket, reinterpret_cast<sockaddr*>(&address), &length);
  if (status == 0 && address.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&address);
    ::inet_ntop(AF_INET, &v4->sin_addr, text, sizeof(text));
    port = ntohs(v4->sin_port);
  } else if (status == 0 && address.ss_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&address);
    ::inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof(text));
    port = ntohs(v6->sin6_port);
  }
  ip = text;
}

GateStream::GateStream(int socket, std::string replay, size_t replay_from,
                       std::chrono::milliseconds read_timeout,
                       std::chrono::milliseconds write_timeout, size_t max_line_bytes,
                       ReadPace pace)
    : socket_(socket),
      replay_(std::move(replay)),
      position_(replay_from),
      read_timeout_(read_timeout),
      write_timeout_(write_timeout),
      max_line_bytes_(max_line_bytes),
      pace_(pace) {}

std::chrono::milliseconds GateStream::PaceLeft() const {
  const auto earned =
      std::chrono::milliseconds(static_cast<int64_t>(bytes_read_ * 1000 / pace_.min_bytes_per_s));
  const auto deadline = started_ + pace_.grace + earned;
  return std::chrono::duration_cast<std::chrono::milliseconds>(deadline -
                                                               std::chrono::steady_clock::now());
}

bool GateStream::WaitReadable() const {
  if (pace_.min_bytes_per_s == 0) return WaitFor(socket_, POLLIN, read_timeout_);
  const std::chrono::milliseconds left = PaceLeft();
  if (left.count() <= 0) return false;
  return WaitFor(socket_, POLLIN, std::min(read_timeout_, left));
}

bool GateStream::is_readable() const { return position_ < replay_.size() || WaitReadable(); }

bool GateStream::is_writable() const { return WaitFor(socket_, POLLOUT, write_timeout_); }

ssize_t GateStream::read(char* ptr, size_t size) {
  if (size == 0) return 0;
  ssize_t n = 0;
  if (position_ < replay_.size()) {
    n = static_cast<ssize_t>(std::min(size, replay_.size() - position_));
    std::memcpy(ptr, replay_.data() + position_, static_cast<size_t>(n));
    position_ += static_cast<size_t>(n);
  } else {
    if (!WaitReadable()) return -1;
    do {
      n = ::recv(socket_, ptr, size, 0);
    } while (n < 0 && errno == EINTR);
    if (n <= 0) return n;
  }
  bytes_read_ += static_cast<uint64_t>(n);
  if (size == 1) {
    line_run_ = ptr[0] == '\n' ? 0 : line_run_ + 1;
    if (line_run_ > max_line_bytes_) return -1;
  } else {
    line_run_ = 0;
  }
  return n;
}

ssize_t GateStream::write(const char* ptr, size_t size) {
  if (!is_writable()) return -1;
  ssize_t n;
  do {
    n = ::send(socket_, ptr, size, MSG_NOSIGNAL);
  } while (n < 0 && errno == EINTR);
  return n;
}

void GateStream::get_remote_ip_and_port(std::string& ip, int& port) const {
  SocketAddress(socket_, true, ip, port);
}

void GateStream::get_local_ip_and_port(std::string& ip, int& port) const {
  SocketAddress(socket_, false, ip, port);
}

std::string GateStream::TakeUnread() {
  std::string rest = replay_.substr(std::min(position_, replay_.size()));
  replay_.clear();
  position_ = 0;
  return rest;
}

}  // namespace dfsm::api
