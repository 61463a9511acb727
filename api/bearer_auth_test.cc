// The bearer-token check on its own: the comparator, header parsing and which
// requests are public.
#include "api/bearer_auth.h"

#include <gtest/gtest.h>

namespace dfsm::api {
namespace {

constexpr const char* kToken = "0123456789abcdef0123456789abcdef";

TEST(ConstantTimeEqualsTest, EqualOnlyForIdenticalStrings) {
  EXPECT_TRUE(ConstantTimeEquals("", ""));
  EXPECT_TRUE(ConstantTimeEquals(kToken, kToken));
  EXPECT_FALSE(ConstantTimeEquals("", kToken));
  EXPECT_FALSE(ConstantTimeEquals(kToken, ""));
  // A prefix, an extension, and the token repeated (the comparator cycles
  // through `expected`, so a repetition must still differ by length).
  EXPECT_FALSE(ConstantTimeEquals("0123456789abcdef", kToken));
  EXPECT_FALSE(ConstantTimeEquals(std::string(kToken) + "0", kToken));
  EXPECT_FALSE(ConstantTimeEquals(std::string(kToken) + kToken, kToken));
  // One differing bit at the first, a middle and the last position.
  for (const size_t position : {size_t{0}, size_t{15}, size_t{31}}) {
    std::string other = kToken;
    other[position] ^= 1;
    EXPECT_FALSE(ConstantTimeEquals(other, kToken)) << position;
  }
  // Bytes above 0x7f and NULs are compared like any other.
  EXPECT_FALSE(ConstantTimeEquals(std::string("a\0b", 3), std::string("a\0c", 3)));
  EXPECT_TRUE(ConstantTimeEquals(std::string("\xff\0", 2), std::string("\xff\0", 2)));
}

TEST(BearerAuthTest, DisabledWithoutAToken) {
  const BearerAuth auth("");
  EXPECT_FALSE(auth.enabled());
  EXPECT_EQ(auth.Check(""), BearerAuth::Verdict::kAllowed);
}

TEST(BearerAuthTest, JudgesTheAuthorizationHeader) {
  const BearerAuth auth(kToken);
  using Verdict = BearerAuth::Verdict;
  EXPECT_EQ(auth.Check(std::string("Bearer ") + kToken), Verdict::kAllowed);
  EXPECT_EQ(auth.Check(std::string("bearer   ") + kToken + " "), Verdict::kAllowed);
  EXPECT_EQ(auth.Check(""), Verdict::kMissing);
  EXPECT_EQ(auth.Check(std::string("Basic ") + kToken), Verdict::kNotBearer);
  EXPECT_EQ(auth.Check(kToken), Verdict::kNotBearer);
  EXPECT_EQ(auth.Check("Bearer "), Verdict::kWrongToken);
  EXPECT_EQ(auth.Check("Bearer 0123456789abcdef0123456789abcdeF"), Verdict::kWrongToken);
  EXPECT_EQ(auth.Check(std::string("Bearer ") + kToken + "x"), Verdict::kWrongToken);
  EXPECT_EQ(auth.Check(std::string("Bearer ") + kToken + " " + kToken), Verdict::kWrongToken);
}

TEST(BearerAuthTest, OnlyProbesTheDescriptionAndPreflightsArePublic) {
  EXPECT_TRUE(BearerAuth::IsPublic("GET", "/healthz"));
  EXPECT_TRUE(BearerAuth::IsPublic("HEAD", "/readyz"));
  EXPECT_TRUE(BearerAuth::IsPublic("GET", "/api/v1/openapi.json"));
  EXPECT_TRUE(BearerAuth::IsPublic("OPTIONS", "/api/v1/jobs"));
  EXPECT_FALSE(BearerAuth::IsPublic("POST", "/healthz"));
  EXPECT_FALSE(BearerAuth::IsPublic("GET", "/healthz/"));
  EXPECT_FALSE(BearerAuth::IsPublic("GET", "/metrics"));
  EXPECT_FALSE(BearerAuth::IsPublic("GET", "/api/v1/jobs"));
  EXPECT_FALSE(BearerAuth::IsPublic("POST", "/api/v1/captures"));
  EXPECT_FALSE(BearerAuth::IsPublic("DELETE", "/api/v1/jobs/j1700000000000-abcd"));
}

TEST(BearerAuthTest, AnswersProblemJsonWithAChallenge) {
  const BearerAuth auth(kToken);
  httplib::Request request;
  request.method = "POST";
  request.path = "/api/v1/captures";
  httplib::Response response;
  EXPECT_FALSE(auth.Authorize(request, response));
  EXPECT_EQ(response.status, 401);
  EXPECT_EQ(response.get_header_value("WWW-Authenticate"), "Bearer realm=\"dfsmd\"");
  EXPECT_EQ(response.get_header_value("Content-Type"), "application/problem+json");
  EXPECT_NE(response.body.find("Authorization: Bearer <token>"), std::string::npos);

  request.headers.emplace("Authorization", "Bearer wrong-token-wrong-token");
  response = {};
  EXPECT_FALSE(auth.Authorize(request, response));
  EXPECT_EQ(response.get_header_value("WWW-Authenticate"),
            "Bearer realm=\"dfsmd\", error=\"invalid_token\"");

  request.headers.clear();
  request.headers.emplace("authorization", std::string("Bearer ") + kToken);
  response = {};
  EXPECT_TRUE(auth.Authorize(request, response));
  EXPECT_EQ(response.status, -1);  // untouched
}

}  // namespace
}  // namespace dfsm::api
