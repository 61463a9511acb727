#include "api/request_head.h"

#include <gtest/gtest.h>

namespace dfsm::api {
namespace {

int StatusOf(const std::string& head) {
  try {
    ParseRequestHead(head);
  } catch (const HeadError& e) {
    return e.status();
  }
  return 200;
}

TEST(RequestHeadTest, FindsTheEndOfTheHead) {
  EXPECT_EQ(FindHeadEnd("GET / HTTP/1.1\r\nHost: a\r\n\r\nbody"), 27u);
  EXPECT_EQ(FindHeadEnd("GET / HTTP/1.1\nHost: a\n\nbody"), 24u);
  EXPECT_EQ(FindHeadEnd("\r\nGET / HTTP/1.1\r\nHost: a\r\n\r\n"), 29u);
  EXPECT_EQ(FindHeadEnd("GET / HTTP/1.1\r\nHost: a\r\n"), std::string::npos);
  EXPECT_EQ(FindHeadEnd(""), std::string::npos);
}

TEST(RequestHeadTest, ParsesARequest) {
  const RequestHead head = ParseRequestHead(
      "POST /api/v1/jobs?frames=5 HTTP/1.1\r\nHost: localhost:8080\r\ncontent-length: 12\r\n"
      "Content-Type:  application/x-tar \r\n\r\n");
  EXPECT_EQ(head.method, "POST");
  EXPECT_EQ(head.target, "/api/v1/jobs?frames=5");
  EXPECT_EQ(head.path, "/api/v1/jobs");
  EXPECT_EQ(*head.content_length, 12u);
  EXPECT_TRUE(head.HasBody());
  EXPECT_EQ(*head.Field("CONTENT-TYPE"), "application/x-tar");
  EXPECT_FALSE(head.WantsClose());
  EXPECT_TRUE(ParseRequestHead("GET / HTTP/1.0\r\n\r\n").WantsClose());
  EXPECT_TRUE(
      ParseRequestHead("GET / HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n").WantsClose());
}

TEST(RequestHeadTest, RefusesAmbiguousOrMalformedHeads) {
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nContent-Length: 1\r\nContent-Length: 1\r\n"),
            400);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nContent-Length: 1, 1\r\n"), 400);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nContent-Length: 0x10\r\n"), 400);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nContent-Length: -1\r\n"), 400);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nTransfer-Encoding: chunked\r\n"
                     "Content-Length: 3\r\n"),
            400);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nTransfer-Encoding: identity\r\n"), 501);
  EXPECT_EQ(StatusOf("GET / HTTP/1.0\r\nTransfer-Encoding: chunked\r\n"), 400);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nNoColon\r\n"), 400);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nName : v\r\n"), 400);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nX: a\x01z\r\n"), 400);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\n"), 400);  // no Host
  EXPECT_EQ(StatusOf("GET /a b HTTP/1.1\r\nHost: a\r\n"), 400);
  EXPECT_EQ(StatusOf("GET nopath HTTP/1.1\r\nHost: a\r\n"), 400);
  EXPECT_EQ(StatusOf("G(T / HTTP/1.1\r\nHost: a\r\n"), 400);
  EXPECT_EQ(StatusOf("PRI * HTTP/2.0\r\n\r\nSM\r\n"), 505);
  EXPECT_EQ(StatusOf("GET / HTTP/1.1\r\nHost: a\r\nContent-Length: 000012\r\n"), 200);
}

TEST(RequestHeadTest, HostNames) {
  EXPECT_EQ(HostName("LocalHost:8080"), "localhost");
  EXPECT_EQ(HostName("[::1]:8080"), "::1");
  EXPECT_EQ(HostName("127.0.0.1"), "127.0.0.1");
  EXPECT_EQ(HostName("camera.local."), "camera.local");
}

}  // namespace
}  // namespace dfsm::api
