// The connection gate: dfsmd's accepted sockets wait here, on one epoll
// thread, until they hold a complete and acceptable request head; only then
// does a worker thread take them.
//
// Why: cpp-httplib 0.11 gives every accepted connection a worker for as long
// as it lasts, and buffers a request line or header line until its newline.
// Eight slowloris connections (a header byte every few seconds), eight
// announced-but-unsent bodies or 200 idle sockets took every worker and
// /healthz stopped answering; a 1 GiB request line took 1.8 GB. Here an idle
// or slow connection costs a file descriptor and at most max_head_bytes, and
// the workers only ever see requests that are ready to be served.
//
// Invariants:
//  - at most `max_connections` sockets are open (held here or being served);
//    at the limit a new connection evicts the oldest one held here, or is
//    refused with 503 when every open connection is being served;
//  - a head is complete within `head_timeout` of its first byte (or of the
//    accept) and no longer than `max_head_bytes`, else 408 or 431;
//  - a kept-alive connection waits at most `keep_alive_timeout` for the first
//    byte of its next request;
//  - a refused connection gets its answer, is half-closed and then drained for
//    at most `linger` (so the client reads the answer instead of a reset).
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "api/request_head.h"

namespace dfsm::api {

struct ConnectionGateOptions {
  int max_connections = 128;
  std::chrono::milliseconds head_timeout{10000};
  std::chrono::milliseconds keep_alive_timeout{5000};
  size_t max_head_bytes = 16384;
  std::chrono::milliseconds linger{1000};

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

// A connection whose next request head is complete and parsed.
struct ReadyRequest {
  int socket = -1;
  std::string bytes;  // what the gate read: the head, and maybe body bytes after it
  size_t head_size = 0;
  RequestHead head;
  int served = 0;  // requests already served on this connection
};

// What to do with a parsed head: serve it (the callback took the request and
// its socket), or answer `response` (a complete HTTP response) and close.
struct HeadVerdict {
  bool serve = false;
  std::string response;
};

class ConnectionGate {
 public:
  using Judge = std::function<HeadVerdict(ReadyRequest& request)>;
  // Formats the gate's own refusals (400, 408, 431, 503, ...) as complete
  // HTTP responses: status, problem slug, detail.
  using Refuse =
      std::function<std::string(int status, const std::string& slug, const std::string& detail)>;

  ConnectionGate(ConnectionGateOptions options, Judge judge, Refuse refuse);
  ~ConnectionGate();  // Stop()
  ConnectionGate(const ConnectionGate&) = delete;
  ConnectionGate& operator=(const ConnectionGate&) = delete;

  void Start();
  // Closes every connection held here and joins the thread. Connections being
  // served are closed by Readmit() from then on.
  void Stop();

  // Takes a freshly accepted socket. Any thread.
  void Admit(int socket);
  // Takes back a served connection for its next request, with the bytes
  // already read past the previous request. Any thread.
  void Readmit(int socket, std::string bytes, int served);
  // Closes a connection that left the gate (served and not kept alive).
  void Close(int socket);
  // Ends a served connection whose client may still be sending (a body the
  // handler did not read): half-closed and drained like a refusal, so that
  // the client reads the answer rather than a reset.
  void Linger(int socket);

  int open_connections() const { return open_.load(); }

 private:
  using Clock = std::chrono::steady_clock;
  // A connection held here: reading its next head, or draining after a refusal.
  struct Connection {
    std::string bytes;
    int served = 0;
    bool draining = false;
    size_t drained = 0;    // bytes thrown away while draining
    bool started = false;  // a byte of the current head arrived
    Clock::time_point admitted;
    Clock::time_point deadline;
  };

  struct Arrival {
    int socket;
    std::string bytes;
    int served;
    bool fresh;
    bool linger = false;
  };

  // Hands `arrival` to the gate thread, or closes its socket once stopping.
  void Enqueue(Arrival arrival);
  void Run();
  void TakeArrivals();
  void Hold(int socket, std::string bytes, int served, bool fresh);
  void OnReadable(int socket);
  void Expire(Clock::time_point now);
  // Tries to complete the head of `socket`; serves, refuses or keeps waiting.
  void Examine(int socket);
  void Answer(int socket, const std::string& response);
  void Drop(int socket);  // closes a held connection
  void EvictOldest();

  const ConnectionGateOptions options_;
  const Judge judge_;
  const Refuse refuse_;
  int epoll_ = -1;
  int wake_ = -1;  // eventfd: arrivals or stop
  std::thread thread_;
  std::atomic<bool> stopping_{true};  // until Start(); set under mutex_
  std::atomic<int> open_{0};

  std::mutex mutex_;  // guards arrivals_
  std::vector<Arrival> arrivals_;

  std::map<int, Connection> held_;  // gate thread only
};

}  // namespace dfsm::api
