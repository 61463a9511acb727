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
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <thread>
#include <vector>

#include "core/io/file_util.h"
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
    config.server.body_grace_ms = 1500;
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

  // A finished job whose depth_filled.tiff holds `bytes` bytes (a 1080p
  // result's size), each byte its offset modulo 251.
  std::string JobWithFile(size_t bytes) {
    const std::string id = routes_->AddJob(service::JobStatus::kSucceeded);
    std::string data(bytes, '\0');
    for (size_t i = 0; i < bytes; ++i) data[i] = static_cast<char>(i % 251);
    const std::filesystem::path output = routes_->store().OutputDir(id);
    std::filesystem::create_directories(output);
    WriteFileAtomically(output / "depth_filled.tiff", data);
    file_ = data;
    return "/api/v1/jobs/" + id + "/depth_filled.tiff";
  }

  std::unique_ptr<RoutesTestHarness> routes_;
  std::string file_;
};

// The status line's header `name` ("" when absent).
std::string HeaderOf(const std::string& answer, const std::string& name) {
  const size_t end = answer.find("\r\n\r\n");
  const std::string head = answer.substr(0, end);
  const std::string key = "\r\n" + name + ": ";
  const size_t at = head.find(key);
  if (at == std::string::npos) return "";
  const size_t from = at + key.size();
  return head.substr(from, head.find("\r\n", from) - from);
}

std::string BodyOf(const std::string& answer) {
  const size_t end = answer.find("\r\n\r\n");
  return end == std::string::npos ? "" : answer.substr(end + 4);
}

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

// 2700 ranges of the whole file in an 8 KiB header made httplib build a
// 3.3 GB multipart body and dfsmd died of bad_alloc; the page's public files
// did the same without a token. The gate lets no Range reach httplib: several
// ranges are ignored (200, the file once), one range is a 206.
TEST_F(HostileClientTest, ManyRangesGetTheWholeFileOnce) {
  const std::string path = JobWithFile(1200 * 1000);
  std::string ranges = "bytes=0-";
  for (int i = 1; i < 2700; ++i) ranges += ",0-";
  for (const char* method : {"GET", "HEAD"}) {
    const std::string answer = Exchange(
        routes_->port(),
        std::string(method) + " " + path +
            " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\nRange: " + ranges + "\r\n\r\n");
    EXPECT_EQ(Status(answer), 200) << method << " " << answer.substr(0, 300);
    EXPECT_EQ(HeaderOf(answer, "Content-Length"), std::to_string(file_.size())) << method;
    EXPECT_EQ(HeaderOf(answer, "Content-Range"), "") << method;
    EXPECT_EQ(BodyOf(answer), std::string(method) == "GET" ? file_ : "") << method;
  }
  // The public page files, the same way.
  const std::string page = Exchange(
      routes_->port(),
      "HEAD /ui/index.html HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\nRange: " + ranges +
          "\r\n\r\n");
  EXPECT_TRUE(Status(page) == 200 || Status(page) == 404) << page.substr(0, 300);
  EXPECT_EQ(HeaderOf(page, "Content-Range"), "");
  ExpectHealthzAnswers(std::chrono::milliseconds(300), "after the range requests");
}

TEST_F(HostileClientTest, OneRangeIsServedAsA206AndAnUnsatisfiableOneIs416) {
  const std::string path = JobWithFile(1200 * 1000);
  const auto get = [&](const std::string& range) {
    return Exchange(routes_->port(), "GET " + path +
                                         " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: "
                                         "close\r\nRange: " +
                                         range + "\r\n\r\n");
  };
  std::string answer = get("bytes=100-199");
  EXPECT_EQ(Status(answer), 206) << answer.substr(0, 300);
  EXPECT_EQ(HeaderOf(answer, "Content-Range"), "bytes 100-199/1200000");
  EXPECT_EQ(BodyOf(answer), file_.substr(100, 100));
  answer = get("bytes=-10");
  EXPECT_EQ(Status(answer), 206);
  EXPECT_EQ(BodyOf(answer), file_.substr(file_.size() - 10));
  answer = get("bytes=1199990-5000000");
  EXPECT_EQ(Status(answer), 206);
  EXPECT_EQ(HeaderOf(answer, "Content-Range"), "bytes 1199990-1199999/1200000");
  answer = get("bytes=5000000-");
  EXPECT_EQ(Status(answer), 416) << answer.substr(0, 300);
  EXPECT_EQ(HeaderOf(answer, "Content-Range"), "bytes */1200000");
  // Another unit, bad syntax, a reversed range: ignored, the whole file.
  for (const char* ignored : {"items=0-5", "bytes=abc", "bytes=9-3", "bytes=0-1,5-6"}) {
    answer = get(ignored);
    EXPECT_EQ(Status(answer), 200) << ignored;
    EXPECT_EQ(BodyOf(answer).size(), file_.size()) << ignored;
  }
  // The gate's own field from a client means nothing.
  answer = Exchange(routes_->port(), "GET " + path +
                                         " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: "
                                         "close\r\nDfsm-Range: 0-9\r\n\r\n");
  EXPECT_EQ(Status(answer), 200);
  EXPECT_EQ(BodyOf(answer).size(), file_.size());
}

// A head ended by a bare LF line ("\r\n\n", which the gate accepts from lax
// clients) was read on by httplib, which skips such a line: the body's lines
// became header fields the gate never judged, a Range of several ranges
// among them (found by the http_socket fuzzer). httplib now gets the head the
// gate judged; the lines after it are a next request, and refused as one.
TEST_F(HostileClientTest, LinesAfterABareLfHeadAreNoHeaderFields) {
  const std::string path = JobWithFile(1000);
  const std::string answer =
      Exchange(routes_->port(), "GET " + path +
                                    " HTTP/1.1\r\nHost: 127.0.0.1\r\n\nRange: bytes=0-,0-,5-9\r\n"
                                    "Connection: close\r\n\r\n");
  EXPECT_EQ(Status(answer), 200) << answer.substr(0, 400);
  EXPECT_EQ(HeaderOf(answer, "Content-Length"), "1000");
  EXPECT_EQ(answer.find("multipart/byteranges"), std::string::npos) << answer.substr(0, 400);
  // The next "request" is the line that was smuggled: a malformed one.
  const size_t next = answer.find("HTTP/1.1 ", 12);
  ASSERT_NE(next, std::string::npos) << answer.substr(0, 400);
  EXPECT_EQ(Status(answer.substr(next)), 400);
}

// What a token protects is never kept by a cache; refusals of the gate are
// counted in /metrics like any answer.
TEST_F(HostileClientTest, ProtectedAnswersAreNotCachedAndRefusalsAreCounted) {
  const std::string path = JobWithFile(1000);
  httplib::Client client("127.0.0.1", routes_->port());
  EXPECT_EQ(client.Get(path.c_str())->get_header_value("Cache-Control"), "no-store");
  EXPECT_EQ(client.Get("/metrics")->get_header_value("Cache-Control"), "no-store");
  EXPECT_EQ(client.Get("/api/v1/calibration")->get_header_value("Cache-Control"), "no-store");
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(
        Status(Exchange(routes_->port(), "GET /healthz HTTP/1.1\r\nHost: evil.example\r\n\r\n")),
        421);
  EXPECT_EQ(Status(Exchange(routes_->port(), "GET /healthz HTTP/1.1\r\n\r\n")), 400);
  const std::string metrics = client.Get("/metrics")->body;
  EXPECT_NE(metrics.find("dfsmd_http_responses_total{code=\"421\"} 3"), std::string::npos)
      << metrics;
  EXPECT_NE(metrics.find("dfsmd_http_responses_total{code=\"400\"} 1"), std::string::npos);
}

// Eight uploads announcing 100 MB and sending a byte every 300 ms held every
// queue place and bulk worker, and a capture request hung. Now the capture is
// refused at once, and the trickles are cut off once they fall behind
// server.min_body_rate after server.body_grace_ms (1.5 s here).
TEST_F(HostileClientTest, TrickledUploadsNeitherHangCapturesNorHoldTheQueue) {
  std::vector<int> uploads;
  for (int i = 0; i < 8; ++i) {
    uploads.push_back(Connect(routes_->port()));
    SendAll(uploads.back(),
            "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/x-tar\r\n"
            "Content-Length: 200000\r\n\r\n");
  }
  std::atomic<bool> stop{false};
  std::thread trickle([&] {
    while (!stop) {
      for (int fd : uploads) SendAll(fd, "x");
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
    }
  });
  const auto start = Clock::now();
  while (!routes_->scheduler().Full() && Clock::now() - start < std::chrono::seconds(2))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(routes_->scheduler().Full());
  const auto asked = Clock::now();
  const std::string refused = Exchange(
      routes_->port(),
      "POST /api/v1/captures HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
      "Content-Length: 2\r\n\r\n{}");
  EXPECT_EQ(Status(refused), 503) << refused.substr(0, 300);
  EXPECT_NE(refused.find("queue is full"), std::string::npos);
  EXPECT_NE(HeaderOf(refused, "Retry-After"), "");
  EXPECT_LT(Clock::now() - asked, std::chrono::milliseconds(1500) + std::chrono::seconds(1));
  ExpectHealthzAnswers(std::chrono::milliseconds(500), "8 trickled uploads");
  // Past the grace, at 3 bytes/s against 500: cut off, the queue drains.
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while (routes_->scheduler().Depth() > 0 && Clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(routes_->scheduler().Depth(), 0);
  stop = true;
  trickle.join();
  for (int fd : uploads) ::close(fd);
  EXPECT_TRUE(routes_->store().List().empty());
}

// A 20 KiB upload with a sparse entry wrote 240 MiB of zeros into the job.
TEST_F(HostileClientTest, ASparseUploadIsRefusedAndWritesNothing) {
  if (std::system("command -v tar >/dev/null 2>&1") != 0) GTEST_SKIP() << "no tar program";
  const std::filesystem::path dir =
      routes_->dir().parent_path() / ("hostile-sparse-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir / "burst");
  WriteFileAtomically(dir / "burst" / "manifest.json", "{}");
  { std::ofstream(dir / "burst" / "zeros.bin", std::ios::binary); }
  // Under server.max_body_bytes (256 KiB here), as 240 MiB was under the default.
  std::filesystem::resize_file(dir / "burst" / "zeros.bin", 200 << 10);
  const std::string command =
      "tar -C " + dir.string() + " -S --format=gnu -cf " + (dir / "sparse.tar").string() + " burst";
  ASSERT_EQ(std::system(command.c_str()), 0);
  const std::string tar = ReadFileToString(dir / "sparse.tar");
  std::filesystem::remove_all(dir);
  EXPECT_LT(tar.size(), 64u << 10);
  httplib::Client client("127.0.0.1", routes_->port());
  const auto answer = client.Post("/api/v1/jobs", tar, "application/x-tar");
  ASSERT_TRUE(answer);
  EXPECT_EQ(answer->status, 422) << answer->body;
  EXPECT_TRUE(answer->body.find("sparse") != std::string::npos ||
              answer->body.find("declares") != std::string::npos)
      << answer->body;
  uintmax_t stored = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(routes_->dir()))
    if (entry.is_regular_file()) stored += entry.file_size();
  EXPECT_LT(stored, 64u << 10);
  EXPECT_TRUE(routes_->store().List().empty());
}

}  // namespace
}  // namespace dfsm::api
