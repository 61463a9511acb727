#include "core/io/bounded_json.h"

#include <gtest/gtest.h>

namespace dfsm {
namespace {

std::string ParseError(const std::string& text, int max_depth = kMaxJsonDepth) {
  try {
    ParseBoundedJson(text, max_depth);
  } catch (const JsonInputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted: " << text.substr(0, 80);
  return "";
}

TEST(BoundedJsonTest, ParsesUpToTheDepthLimit) {
  const std::string at_limit = std::string(3, '[') + "1" + std::string(3, ']');
  EXPECT_EQ(ParseBoundedJson(at_limit, 3).dump(), "[[[1]]]");
  EXPECT_EQ(ParseError(at_limit, 2), "nested deeper than 2 arrays/objects (at byte 2)");
}

TEST(BoundedJsonTest, CountsObjectsAndArraysButNotBracketsInStrings) {
  EXPECT_EQ(ParseBoundedJson(R"({"a":"[[[{{{\"[[["})", 1)["a"], "[[[{{{\"[[[");
  EXPECT_NE(ParseError(R"({"a":{"b":[]}})", 2).find("nested deeper than 2"), std::string::npos);
}

TEST(BoundedJsonTest, RefusesAHostileDepthBeforeParsing) {
  const int depth = 1000000;  // 2 MB: would overflow the stack of any recursive walk
  const std::string error = ParseError(std::string(depth, '[') + std::string(depth, ']'));
  EXPECT_NE(error.find("nested deeper than 64"), std::string::npos) << error;
}

TEST(BoundedJsonTest, MalformedTextAndHugeNumbersAreInputErrors) {
  EXPECT_NE(ParseError("{not json").find("not valid JSON"), std::string::npos);
  EXPECT_NE(ParseError("[1e999]").find("not valid JSON"), std::string::npos);
}

TEST(BoundedJsonTest, DescribesContainersBySizeAndShortensScalars) {
  EXPECT_EQ(DescribeJsonValue(nlohmann::json::array({1, 2})), "an array of 2 elements");
  EXPECT_EQ(DescribeJsonValue(nlohmann::json::object()), "an object of 0 members");
  EXPECT_EQ(DescribeJsonValue(42), "42");
  EXPECT_EQ(DescribeJsonValue(std::string(100, 'x'), 10), "\"xxxxxxxxx...");
}

}  // namespace
}  // namespace dfsm
