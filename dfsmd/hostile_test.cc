// dfsmd's HTTP front against hostile and careless clients over real sockets
// (the hardening issue's reproductions, each bounded in time): connection
// attacks must not starve /healthz, framing must be unambiguous, and
// cross-site requests must be refused before anything is read or stored.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <iostream>
#include <thread>
#include <vector>

#include "dfsmd/routes_test_harness.h"

namespace dfsm::api {
namespace {

using Clock = std::chrono::steady_clock;

int Connect(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

void SendAll(int fd, const std::string& bytes) {
  size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return;
    sent += static_cast<size_t>(n);
  }
}

// Reads until the server closes or stays silent for `quiet`.
std::string ReadAnswer(int fd, std::chrono::milliseconds quiet = std::chrono::milliseconds(1500)) {
  timeval timeout{0, static_cast<suseconds_t>(quiet.count() * 1000)};
  if (quiet.count() >= 1000) timeout = {quiet.count() / 1000, (quiet.count() % 1000) * 1000};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  std::string answer;
  char buffer[4096];
  for (ssize_t n; (n = ::recv(fd, buffer, sizeof(buffer), 0)) > 0;)
    answer.append(buffer, static_cast<size_t>(n));
  return answer;
}

std::string Exchange(int port, const std::string& bytes) {
  const int fd = Connect(port);
  if (fd < 0) return "";
  SendAll(fd, bytes);
  std::string answer = ReadAnswer(fd);
  ::close(fd);
  return answer;
}

int Status(const std::string& answer) {
  if (answer.rfind("HTTP/1.1 ", 0) != 0 || answer.size() < 12) return 0;
  return std::stoi(answer.substr(9, 3));
}

class HostileClientTest : public ::testing::Test {
 protected:
  void SetUp() override {
    service::DaemonConfig config;
    config.server.port = 0;
    config.server.max_body_bytes = 256 << 10;
    config.server.head_timeout_ms = 1500;
    config.server.max_connections = 64;
    routes_ = std::make_unique<RoutesTestHarness>("dfsm-hostile-test", config);
  }

  // /healthz answer times over `duration`, probing every 100 ms; an
  // unanswered probe counts as 10 s.
  struct Latency {
    std::chrono::milliseconds median{0}, worst{0};
  };
  Latency HealthzLatency(std::chrono::milliseconds duration) {
    httplib::Client client("127.0.0.1", routes_->port());
    client.set_connection_timeout(std::chrono::seconds(2));
    client.set_read_timeout(std::chrono::seconds(2));
    std::vector<std::chrono::milliseconds> times;
    for (const auto end = Clock::now() + duration; Clock::now() < end;) {
      const auto start = Clock::now();
      const auto result = client.Get("/healthz");
      auto took = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start);
      if (!result || result->status != 200) took = std::chrono::seconds(10);
      times.push_back(took);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    std::sort(times.begin(), times.end());
    return {times[times.size() / 2], times.back()};
  }

  // The target is an answer within 1 s throughout an attack (before the gate:
  // none for 20-50 s). On a shared, loaded CI machine a single probe may take
  // a scheduling hiccup longer, so the median must meet it and the worst may
  // not exceed 3 s; both are printed.
  void ExpectHealthzAnswers(std::chrono::milliseconds duration, const char* attack) {
    const Latency latency = HealthzLatency(duration);
    std::cout << attack << ": /healthz median " << latency.median.count() << " ms, worst "
              << latency.worst.count() << " ms\n";
    EXPECT_LT(latency.median.count(), 1000) << attack;
    EXPECT_LT(latency.worst.count(), 3000) << attack;
  }

  std::unique_ptr<RoutesTestHarness> routes_;
};

TEST_F(HostileClientTest, SlowlorisConnectionsNeitherStarveHealthzNorLastBeyondTheHeadTimeout) {
  // Twelve connections (more than the 8 bulk and 2 control workers) each
  // dribbling a header byte every 200 ms.
  std::vector<int> slow;
  for (int i = 0; i < 12; ++i) {
    slow.push_back(Connect(routes_->port()));
    SendAll(slow.back(), "GET /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\n");
  }
  std::atomic<bool> stop{false};
  std::thread dribble([&] {
    while (!stop) {
      for (int fd : slow) SendAll(fd, "X");
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  });
  ExpectHealthzAnswers(std::chrono::milliseconds(1200), "12 slowloris connections");
  stop = true;
  dribble.join();
  // server.head_timeout_ms (1.5 s) ends them with 408.
  for (int fd : slow) {
    EXPECT_EQ(Status(ReadAnswer(fd, std::chrono::milliseconds(2500))), 408);
    ::close(fd);
  }
}

TEST_F(HostileClientTest, IdleSocketsBeyondTheConnectionLimitDoNotStarveHealthz) {
  std::vector<int> idle;
  for (int i = 0; i < 200; ++i) {
    const int fd = Connect(routes_->port());
    if (fd >= 0) idle.push_back(fd);
  }
  ExpectHealthzAnswers(std::chrono::milliseconds(800), "200 idle sockets");
  for (int fd : idle) ::close(fd);
}

TEST_F(HostileClientTest, AnnouncedButUnsentBodiesOccupyOnlyTheBulkWorkers) {
  // Ten uploads that announce 200 KiB and send nothing: the bulk workers wait
  // for bodies (up to the read timeout); probes run on the control workers.
  std::vector<int> uploads;
  for (int i = 0; i < 10; ++i) {
    uploads.push_back(Connect(routes_->port()));
    SendAll(uploads.back(),
            "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/x-tar\r\n"
            "Content-Length: 204800\r\n\r\n");
  }
  ExpectHealthzAnswers(std::chrono::milliseconds(1000), "10 announced-but-unsent uploads");
  httplib::Client client("127.0.0.1", routes_->port());
  client.set_read_timeout(std::chrono::seconds(2));
  const auto list = client.Get("/api/v1/jobs");
  ASSERT_TRUE(list);
  EXPECT_EQ(list->status, 200);
  for (int fd : uploads) ::close(fd);
}

TEST_F(HostileClientTest, AnEndlessRequestLineIsRefusedAtTheHeadLimit) {
  const int fd = Connect(routes_->port());
  // 1 MiB without a newline: the gate stops reading at server.max_head_bytes.
  const std::string line = "GET /" + std::string(1 << 20, 'a');
  SendAll(fd, line.substr(0, 64 << 10));
  const std::string answer = ReadAnswer(fd);
  EXPECT_EQ(Status(answer), 431) << answer.substr(0, 200);
  EXPECT_NE(answer.find("server.max_head_bytes"), std::string::npos);
  ::close(fd);
  // A header line, likewise.
  EXPECT_EQ(Status(Exchange(routes_->port(), "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX: " +
                                                 std::string(32 << 10, 'b'))),
            431);
}

TEST_F(HostileClientTest, AmbiguousFramingIsRefused) {
  const std::string start =
      "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\n"
      "Content-Type: application/x-tar\r\n";
  struct Case {
    std::string head;
    int status;
  };
  for (const Case& c : std::vector<Case>{
           {start + "Content-Length: 5\r\nContent-Length: 6\r\n\r\n", 400},
           {start + "Content-Length: 5\r\nTransfer-Encoding: chunked\r\n\r\n", 400},
           {start + "Content-Length: abc\r\n\r\n", 400},
           {start + "Content-Length: +5\r\n\r\n", 400},
           {start + "Content-Length: 99999999999999999999999\r\n\r\n", 400},
           {start + "Transfer-Encoding: gzip, chunked\r\n\r\n", 501},
           {start + "X-No-Colon\r\nContent-Length: 0\r\n\r\n", 400},
           {start + "Bad Name: 1\r\nContent-Length: 0\r\n\r\n", 400},
           {start + " folded\r\nContent-Length: 0\r\n\r\n", 400},
           {"GET /healthz HTTP/1.1\r\n\r\n", 400},  // no Host
           {"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nHost: localhost\r\n\r\n", 400},
           {"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n", 505},
           {"GET /healthz HTTP/3.0\r\nHost: 127.0.0.1\r\n\r\n", 505},
       }) {
    const std::string answer = Exchange(routes_->port(), c.head);
    EXPECT_EQ(Status(answer), c.status) << c.head << "\n" << answer.substr(0, 300);
    EXPECT_NE(answer.find("application/problem+json"), std::string::npos) << c.head;
  }
  EXPECT_TRUE(routes_->store().List().empty());
}

TEST_F(HostileClientTest, AnOversizedBodyIsRefusedAtOnceWithoutContinue) {
  const auto start = Clock::now();
  const std::string answer = Exchange(
      routes_->port(),
      "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/x-tar\r\n"
      "Content-Length: 1073741824\r\nExpect: 100-continue\r\n\r\n");
  EXPECT_EQ(Status(answer), 413) << answer;
  EXPECT_EQ(answer.find("100 Continue"), std::string::npos);
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(2));
}

TEST_F(HostileClientTest, AnEndlessChunkSizeLineIsNotBuffered) {
  const int fd = Connect(routes_->port());
  SendAll(fd,
          "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/x-tar\r\n"
          "Transfer-Encoding: chunked\r\n\r\n");
  // 1 MiB of chunk-size digits, no newline: the stream fails the line at
  // server.max_head_bytes and the connection ends.
  SendAll(fd, std::string(1 << 20, '1'));
  const std::string answer = ReadAnswer(fd);
  EXPECT_TRUE(answer.empty() || Status(answer) == 400 || Status(answer) == 413)
      << answer.substr(0, 200);
  ::close(fd);
  EXPECT_TRUE(routes_->store().List().empty());
}

TEST_F(HostileClientTest, ForeignHostNamesAreMisdirected) {
  // DNS rebinding: a page of evil.example resolved to 127.0.0.1.
  const std::string rebound =
      Exchange(routes_->port(), "GET /api/v1/jobs HTTP/1.1\r\nHost: evil.example:8080\r\n\r\n");
  EXPECT_EQ(Status(rebound), 421) << rebound;
  EXPECT_NE(rebound.find("server.allowed_hosts"), std::string::npos);
  for (const std::string host :
       {"127.0.0.1", "localhost", "LOCALHOST:8080", "[::1]:8080", "192.0.2.4"}) {
    EXPECT_EQ(Status(Exchange(routes_->port(), "GET /healthz HTTP/1.1\r\nHost: " + host +
                                                   "\r\nConnection: close\r\n\r\n")),
              200)
        << host;
  }
}

TEST_F(HostileClientTest, CrossSiteRequestsWithoutPreflightAreRefused) {
  const std::string capture = "POST /api/v1/captures HTTP/1.1\r\nHost: 127.0.0.1:8080\r\n";
  // What a page on another site can send without a CORS preflight.
  EXPECT_EQ(Status(Exchange(routes_->port(), capture + "Content-Type: text/plain\r\n"
                                                       "Content-Length: 2\r\n\r\n{}")),
            415);
  EXPECT_EQ(Status(Exchange(routes_->port(), capture + "Content-Length: 0\r\n\r\n")), 415);
  EXPECT_EQ(Status(Exchange(routes_->port(),
                            capture + "Origin: https://evil.example\r\nContent-Type: "
                                      "application/json\r\nContent-Length: 2\r\n\r\n{}")),
            403);
  const std::string upload = "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\n";
  EXPECT_EQ(Status(Exchange(routes_->port(), upload + "Content-Length: 3\r\n\r\nabc")), 415);
  EXPECT_EQ(Status(Exchange(routes_->port(), upload + "Content-Type: application/x-tarball\r\n"
                                                      "Content-Length: 3\r\n\r\nabc")),
            415);
  // The same origin (a page dfsmd serves) is fine: here, a capture that finds
  // no capture source.
  EXPECT_EQ(Status(Exchange(routes_->port(),
                            capture + "Origin: http://127.0.0.1:8080\r\nContent-Type: "
                                      "application/json\r\nContent-Length: 2\r\n\r\n{}")),
            503);
  EXPECT_TRUE(routes_->store().List().empty());
}

TEST_F(HostileClientTest, UnsupportedMethodsAreNamed) {
  const std::string put = Exchange(
      routes_->port(), "PUT /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 0\r\n\r\n");
  EXPECT_EQ(Status(put), 405) << put;
  EXPECT_NE(put.find("Allow: GET, HEAD, POST"), std::string::npos) << put;
  EXPECT_EQ(Status(Exchange(routes_->port(),
                            "PATCH /api/v1/calibration HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")),
            405);
  EXPECT_EQ(Status(Exchange(routes_->port(), "TRACE / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")), 501);
  EXPECT_EQ(Status(Exchange(routes_->port(), "PUT /nowhere HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")),
            404);
}

TEST_F(HostileClientTest, PipelinedRequestsOnOneConnectionAreAllAnswered) {
  const std::string get = "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  const std::string answer = Exchange(routes_->port(), get + get + get);
  size_t count = 0;
  for (size_t at = answer.find("HTTP/1.1 200"); at != std::string::npos;
       at = answer.find("HTTP/1.1 200", at + 1))
    ++count;
  EXPECT_EQ(count, 3u) << answer;
}

}  // namespace
}  // namespace dfsm::api
