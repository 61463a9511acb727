#include "bench/report_options.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace dfsm {
namespace {

// The message a refused value gets, or "" where it is taken.
template <typename Parse>
std::string Refusal(Parse parse) {
  try {
    parse();
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "";
}

TEST(ReportOptions, WholeNumbersMustBeAllOfTheTextAndInRange) {
  EXPECT_EQ(WholeNumber("--bursts", "64", 1), 64);
  EXPECT_EQ(WholeNumber("--only", "0", 0), 0);
  EXPECT_EQ(WholeNumber("--reweight-rounds", "0", 0), 0);
  EXPECT_EQ(Refusal([] { WholeNumber("--bursts", "abc", 1); }),
            "--bursts takes a whole number >= 1, got 'abc'");
  for (const char* text : {"", "3x", " 3", "3 ", "1.5", "0", "-2", "99999999999"})
    EXPECT_NE(Refusal([&] { WholeNumber("--frames", text, 1); }), "") << "'" << text << "'";
}

TEST(ReportOptions, RealNumbersMustBeFinite) {
  EXPECT_DOUBLE_EQ(RealNumber("--cell-scale", "0.5"), 0.5);
  EXPECT_DOUBLE_EQ(RealNumber("--lens-prior", "-1e-3"), -1e-3);
  EXPECT_EQ(Refusal([] { RealNumber("--cell-scale", "half"); }),
            "--cell-scale takes a number, got 'half'");
  for (const char* text : {"", "0.5x", " 1", "nan", "inf", "1e999"})
    EXPECT_NE(Refusal([&] { RealNumber("--cell-scale", text); }), "") << "'" << text << "'";
}

TEST(ReportOptions, SeedsAreWholeNumbersFromZero) {
  EXPECT_EQ(SeedNumber("--seed", "0"), 0u);
  EXPECT_EQ(SeedNumber("--seed", "18446744073709551615"), 18446744073709551615ull);
  for (const char* text : {"", "-1", "+1", "1e3", "12a", "18446744073709551616"})
    EXPECT_NE(Refusal([&] { SeedNumber("--seed", text); }), "") << "'" << text << "'";
}

}  // namespace
}  // namespace dfsm
