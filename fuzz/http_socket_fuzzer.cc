// Fuzzes dfsmd's whole request path through a real socket: raw bytes, framing
// included, go to the listening port of the daemon's real parts (fuzz_daemon.h)
// and pass everything a client meets: httplib's accept, the connection gate
// (head limits, the strict head parser, the request guard), the worker lanes,
// httplib's request processing and the routes. "{J0}".."{J3}" stand for the
// fixture jobs' ids, as in http_fuzzer.cc (which runs the same path in process,
// much faster, without the socket and the gate's threads).
//
// What must hold: no crash; the connection ends within a few seconds of the
// client's half-close, plus however late a starved or stopped process woke
// meanwhile (nothing hangs); every answer is a well-formed status
// line, no 500, errors as problem+json; /healthz still answers afterwards.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <string>
#include <vector>

#include "fuzz/fuzz_check.h"
#include "fuzz/fuzz_daemon.h"
#include "fuzz/http_check.h"

namespace {

// Connects without being cut short by a signal: libFuzzer's timeout alarm
// fires every second, and a connect() that blocks (a SYN that meets one of
// the server's TIME_WAIT connections with the same ports waits a second for
// its retry, which at ~2000 connections a second happens within a minute)
// failed with EINTR instead of completing.
int Connect(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  FUZZ_CHECK(fd >= 0, std::string("socket: ") + std::strerror(errno));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  int error = 0;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
    error = errno;
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (error == EINPROGRESS && std::chrono::steady_clock::now() < end) {
      pollfd p{fd, POLLOUT, 0};
      if (::poll(&p, 1, 100) <= 0) continue;  // nothing yet, or EINTR: look again
      socklen_t length = sizeof(error);
      ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &length);
    }
  }
  FUZZ_CHECK(error == 0, std::string("dfsmd does not accept connections: ") +
                             std::strerror(error == EINPROGRESS ? ETIMEDOUT : error));
  // Blocking again for the exchange (send() then waits for buffer space).
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  return fd;
}

// A starved or stopped process may stretch a connection's deadline by at
// most this much.
constexpr std::chrono::seconds kMostLateness{55};

// Sends `bytes`, half-closes, and reads until the server closes. Returns
// false when it is still open after `limit` (a hung connection). The limit
// is stretched by how late this thread woke from its waits: on a machine
// starved by other work (a CI's sanitizer builds held both cores during the
// campaign of 2026-11-26, fuzz/README.md), or while the process was stopped,
// an answer may take longer than `limit` without anything hanging, and the
// daemon's threads were held up as long as this one was. A hung connection
// leaves the machine idle, and the waits end on time.
bool Exchange(int port, const std::string& bytes, std::string* answer,
              std::chrono::milliseconds limit) {
  const int fd = Connect(port);
  for (size_t sent = 0; sent < bytes.size();) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;  // libFuzzer's alarm
    if (n <= 0) break;                      // the server refused early and closed: fine
    sent += static_cast<size_t>(n);
  }
  ::shutdown(fd, SHUT_WR);
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  Clock::duration lateness{};  // woken after the wait asked for, summed
  bool closed = false;
  char buffer[16384];
  while (true) {
    const auto now = Clock::now();
    const auto end = start + limit + std::min<Clock::duration>(lateness, kMostLateness);
    if (now >= end) break;
    // Short waits, so that a late wake-up shows soon.
    const int wait_ms = static_cast<int>(std::clamp<int64_t>(
        std::chrono::duration_cast<std::chrono::milliseconds>(end - now).count(), 1, 100));
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, wait_ms);
    if (ready == 0) {
      const auto over = Clock::now() - now - std::chrono::milliseconds(wait_ms);
      if (over > std::chrono::milliseconds(10)) lateness += over;
    }
    if (ready <= 0) continue;
    const ssize_t n = ::recv(fd, buffer, sizeof(buffer), 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      closed = true;
      break;
    }
    if (answer->size() < (1 << 20)) answer->append(buffer, static_cast<size_t>(n));
  }
  ::close(fd);
  return closed;
}

}  // namespace

// libFuzzer checks for leaks after an input whose mallocs and frees do not
// balance. The daemon's threads (the gate, the workers) allocate and free beside
// every input, so they almost never balance here, and each input paid for a
// whole LeakSanitizer scan: 80 % of the time, 255 executions per second against
// 1195 without (measured 2026-11-26). Leaks are for the in-process http harness
// and the ASan stage to find. Inserted first: a -detect_leaks=1 given on the
// command line still wins.
//
// libFuzzer's own per-input timeout (-timeout=10 in ctest_fuzz.sh and
// run-fuzz.sh) would cut the stretched deadlines of Exchange short, so it is
// set here, last, which wins over the command line: two exchanges of at most
// 5 s + kMostLateness each, and a margin. The harness's deadlines are what
// detect a hang; this is only the backstop.
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  static char no_leak_check[] = "-detect_leaks=0";
  static char input_timeout[] = "-timeout=130";
  static std::vector<char*> args;
  args.assign(*argv, *argv + *argc);
  args.insert(args.begin() + (args.empty() ? 0 : 1), no_leak_check);
  args.push_back(input_timeout);
  args.push_back(nullptr);
  *argc = static_cast<int>(args.size()) - 1;
  *argv = args.data();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static dfsm::fuzz::FuzzDaemon daemon;
  static const int port = daemon.Listen();
  daemon.Restore();
  const std::string input = dfsm::fuzz::SubstituteFixtures(
      std::string_view(reinterpret_cast<const char*>(data), size), daemon);
  std::string answer;
  // The head timeout of the fuzz configuration bounds a partial head; the
  // event stream lasts 1 s there: a connection must end well within 5 s.
  FUZZ_CHECK(Exchange(port, input, &answer, std::chrono::seconds(5)),
             "the connection did not end within 5 s of the client's half-close");
  dfsm::fuzz::CheckResponses(answer);
  std::string health;
  FUZZ_CHECK(Exchange(port, "GET /healthz HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n",
                      &health, std::chrono::seconds(5)) &&
                 health.rfind("HTTP/1.1 200", 0) == 0,
             "/healthz does not answer after the input: " + health.substr(0, 200));
  return 0;
}
