// Fuzzes dfsmd's HTTP surface: a raw request (or several, kept alive) goes
// through cpp-httplib's parser into the real routes of api/routes.cc, bearer
// authentication and CORS included, on the daemon's real parts (fuzz_daemon.h):
// job store, scheduler (never started: no pipeline runs), intake, metrics and
// a replay capture source. Every route is reachable: the seeds hold a request
// for each, and "{J0}".."{J3}" in an input stand for the ids of the fixture
// jobs (processing, succeeded, failed, queued).
//
// What must hold: no crash, no 500 (an exception escaping a handler is a bug),
// every error answered as problem+json, and the store back to its fixtures
// after each input (jobs made by the input are deleted, deleted fixtures made
// again), so the state stays bounded over millions of inputs.
#include <httplib.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "api/request_head.h"
#include "fuzz/fuzz_check.h"
#include "fuzz/fuzz_daemon.h"
#include "fuzz/http_check.h"

namespace {

// The request bytes as a connection: reads consume the input, writes collect
// the response.
class BufferStream final : public httplib::Stream {
 public:
  explicit BufferStream(std::string_view input) : input_(input) {}

  bool is_readable() const override { return true; }
  bool is_writable() const override { return true; }
  ssize_t read(char* ptr, size_t size) override {
    const size_t n = std::min(size, input_.size() - position_);
    if (n > 0) std::memcpy(ptr, input_.data() + position_, n);
    position_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    output_.append(ptr, size);
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = "192.0.2.7";  // not loopback: nothing may depend on where a request comes from
    port = 50000;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = "192.0.2.1";
    port = 8080;
  }
  socket_t socket() const override { return INVALID_SOCKET; }

  std::string_view remaining() const { return input_.substr(position_); }
  std::string TakeOutput() { return std::move(output_); }

 private:
  std::string_view input_;
  size_t position_ = 0;
  std::string output_;
};

// process_request is protected; a pointer to it formed in a derived class may
// be applied to the base object, so the harness serves through the real
// api::HttpServer's httplib::Server (its limits, timeouts and routes) with no
// socket in between.
struct ServerAccess : httplib::Server {
  static constexpr auto kProcessRequest = &ServerAccess::process_request;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static dfsm::fuzz::FuzzDaemon daemon;
  daemon.Restore();
  const std::string input = dfsm::fuzz::SubstituteFixtures(
      std::string_view(reinterpret_cast<const char*>(data), size), daemon);
  std::string pending = input;  // what is left of the connection's bytes
  httplib::Server* server = daemon.server();
  // Up to 4 requests on one keep-alive connection, as a client may pipeline
  // them; each passes what the connection gate does with a real socket
  // (api/connection_gate.h) before httplib sees it: the head's end within
  // server.max_head_bytes, the strict head parser, the request guard, and the
  // head handed on as the gate hands it (api/http_server.h, HandedOnHead).
  for (int request = 0; request < 4 && !pending.empty(); ++request) {
    const std::string_view rest = pending;
    const size_t end = dfsm::api::FindHeadEnd(rest.substr(0, daemon.max_head_bytes() + 1));
    if (end == std::string_view::npos || end > daemon.max_head_bytes()) break;  // 431 or 408
    dfsm::api::RequestHead head;
    try {
      head = dfsm::api::ParseRequestHead(rest.substr(0, end));
    } catch (const dfsm::api::HeadError& error) {
      FUZZ_CHECK(error.status() == 400 || error.status() == 501 || error.status() == 505,
                 "unexpected head status " + std::to_string(error.status()));
      FUZZ_CHECK(std::string(error.what()).size() > 0, "a head refusal without a reason");
      break;
    }
    dfsm::api::Lane lane;
    if (const std::optional<std::string> refusal = daemon.http().Judge(head, &lane)) {
      dfsm::fuzz::CheckResponse(*refusal);
      break;
    }
    pending = dfsm::api::HandedOnHead(head) + pending.substr(end);
    BufferStream stream(pending);
    bool connection_closed = false;
    const bool ok = (server->*ServerAccess::kProcessRequest)(
        stream, /*close_connection=*/false, connection_closed,
        [](httplib::Request& r) { r.remote_addr = "192.0.2.7"; });
    const std::string response = stream.TakeOutput();
    // DFSM_FUZZ_TRACE=1: the status line of every answer, to see what seeds reach.
    static const bool trace = std::getenv("DFSM_FUZZ_TRACE") != nullptr;
    if (trace) std::fprintf(stderr, "-> %s\n", response.substr(0, response.find('\r')).c_str());
    dfsm::fuzz::CheckResponse(response);
    if (!ok || connection_closed) break;
    pending = std::string(stream.remaining());
  }
  return 0;
}
