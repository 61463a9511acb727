// The httplib::Stream through which a worker serves a request the connection
// gate (connection_gate.h) has admitted: it first replays the bytes the gate
// already read (the head, maybe the start of the body), then reads the socket
// with poll-based timeouts.
//
// A run of single-byte reads is how httplib reads a line (chunk sizes and
// trailers of a chunked body); such a run longer than `max_line_bytes` without
// a newline fails the read, so no line is buffered without bound. A read that
// would fall behind the ReadPace fails too.
#pragma once

#include <httplib.h>

#include <chrono>
#include <string>

namespace dfsm::api {

// The address and port of a connected socket's peer (`peer`) or of its own
// end; "" and 0 when the socket has none.
void SocketAddress(int socket, bool peer, std::string& ip, int& port);

// How fast a request must keep arriving once a worker serves it: within
// `grace` of the start, then at `min_bytes_per_s` on average (the rule of
// Apache's mod_reqtimeout, body=20,MinRate=500). A body trickled a byte every
// few seconds would otherwise hold a worker and the job queue place it
// reserved for as long as the trickle lasts.
struct ReadPace {
  std::chrono::milliseconds grace{20000};
  uint64_t min_bytes_per_s = 500;  // 0: no pace, only the read timeout
};

class GateStream final : public httplib::Stream {
 public:
  GateStream(int socket, std::string replay, size_t replay_from,
             std::chrono::milliseconds read_timeout, std::chrono::milliseconds write_timeout,
             size_t max_line_bytes, ReadPace pace = {});

  bool is_readable() const override;
  bool is_writable() const override;
  ssize_t read(char* ptr, size_t size) override;
  ssize_t write(const char* ptr, size_t size) override;
  void get_remote_ip_and_port(std::string& ip, int& port) const override;
  void get_local_ip_and_port(std::string& ip, int& port) const override;
  socket_t socket() const override { return socket_; }

  // The replayed bytes not read yet (a pipelined next request).
  std::string TakeUnread();
  // Bytes read so far (replayed ones included).
  uint64_t bytes_read() const { return bytes_read_; }

 private:
  bool WaitReadable() const;
  // Time left before the read pace is missed (zero or less: missed); the
  // pace must be on.
  std::chrono::milliseconds PaceLeft() const;

  const int socket_;
  std::string replay_;
  size_t position_;
  const std::chrono::milliseconds read_timeout_;
  const std::chrono::milliseconds write_timeout_;
  const size_t max_line_bytes_;
  const ReadPace pace_;
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  uint64_t bytes_read_ = 0;
  size_t line_run_ = 0;  // bytes of the current run of single-byte reads without '\n'
};

}  // namespace dfsm::api
