// Whole-string number parsing: only a plain decimal number is a number.
#include "daemon/service/number_text.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>

namespace dfsm::service {
namespace {

TEST(NumberTextTest, ParsesPlainIntegers) {
  EXPECT_EQ(ParseInteger("12"), 12);
  EXPECT_EQ(ParseInteger("0"), 0);
  EXPECT_EQ(ParseInteger("-7"), -7);
  EXPECT_EQ(ParseInteger("007"), 7);
  EXPECT_EQ(ParseInteger("9223372036854775807"), std::numeric_limits<int64_t>::max());
  EXPECT_EQ(ParseInteger("-9223372036854775808"), std::numeric_limits<int64_t>::min());
  // A caller's std::string converts as before.
  EXPECT_EQ(ParseInteger(std::string("42")), 42);
}

TEST(NumberTextTest, RefusesAnythingButAPlainInteger) {
  for (const char* text : {"", " 12", "12 ", "\t12", "12\n", "+12", "12abc", "abc", "1.5", "1e3",
                           "0x1A", "--1", "-", "+", "1 2", "1,000", "1_000", "inf", "nan"}) {
    EXPECT_FALSE(ParseInteger(text)) << "'" << text << "'";
  }
  // A NUL inside the text is not the end of it.
  EXPECT_FALSE(
      ParseInteger(std::string("12\0"
                               "3",
                               4)));
}

TEST(NumberTextTest, RefusesIntegersOutOfRange) {
  EXPECT_FALSE(ParseInteger("9223372036854775808"));
  EXPECT_FALSE(ParseInteger("-9223372036854775809"));
  EXPECT_FALSE(ParseInteger("99999999999999999999999"));
}

TEST(NumberTextTest, ParsesPlainReals) {
  EXPECT_EQ(ParseReal("12"), 12.0);
  EXPECT_EQ(ParseReal("-0.25"), -0.25);
  EXPECT_EQ(ParseReal("1.5"), 1.5);
  EXPECT_EQ(ParseReal("1e3"), 1000.0);
  EXPECT_EQ(ParseReal("2.5E-1"), 0.25);
  EXPECT_EQ(ParseReal(".5"), 0.5);
  EXPECT_EQ(ParseReal("5."), 5.0);
  EXPECT_EQ(ParseReal("1.7976931348623157e308"), std::numeric_limits<double>::max());
}

TEST(NumberTextTest, RefusesAnythingButAPlainReal) {
  for (const char* text :
       {"",    " 1.5",  "1.5 ", "+1.5", "1.5x", "x",        ".",   "e3",  "1e",   "1e+",   "--1",
        "1,5", "0x1p3", "inf",  "-inf", "INF",  "infinity", "nan", "NaN", "-nan", "nan(1)"}) {
    EXPECT_FALSE(ParseReal(text)) << "'" << text << "'";
  }
}

TEST(NumberTextTest, RefusesRealsOutOfRange) {
  EXPECT_FALSE(ParseReal("1e999"));
  EXPECT_FALSE(ParseReal("-1e999"));
}

}  // namespace
}  // namespace dfsm::service
