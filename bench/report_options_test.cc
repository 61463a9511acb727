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
  for (const char* text :
       {"", "3x", " 3", "3 ", "+3", "0x10", "1e3", "1.5", "0", "-2", "99999999999"})
    EXPECT_NE(Refusal([&] { WholeNumber("--frames", text, 1); }), "") << "'" << text << "'";
}

TEST(ReportOptions, NumbersMustBeFiniteAndInRange) {
  EXPECT_DOUBLE_EQ(PositiveNumber("--cell-scale", "0.5"), 0.5);
  EXPECT_DOUBLE_EQ(PositiveNumber("--corner-prior", "1e-3"), 1e-3);
  EXPECT_DOUBLE_EQ(NonNegativeNumber("--lens-prior", "0"), 0.0);
  EXPECT_EQ(Refusal([] { PositiveNumber("--cell-scale", "half"); }),
            "--cell-scale takes a number > 0, got 'half'");
  EXPECT_EQ(Refusal([] { NonNegativeNumber("--lens-prior", "-1e-3"); }),
            "--lens-prior takes a number >= 0, got '-1e-3'");
  for (const char* text :
       {"", "0", "-1", "0.5x", " 1", "+1", "0x1p-1", ".5", "nan", "inf", "1e999", "1e-400"})
    EXPECT_NE(Refusal([&] { PositiveNumber("--cell-scale", text); }), "") << "'" << text << "'";
}

TEST(ReportOptions, SeedsAreWholeNumbersFromZero) {
  EXPECT_EQ(SeedNumber("--seed", "0"), 0u);
  EXPECT_EQ(SeedNumber("--seed", "18446744073709551615"), 18446744073709551615ull);
  for (const char* text : {"", "-1", "+1", "1e3", "12a", "18446744073709551616"})
    EXPECT_NE(Refusal([&] { SeedNumber("--seed", text); }), "") << "'" << text << "'";
}

TEST(ReportOptions, SwitchesAreOnOrOff) {
  EXPECT_TRUE(OnOff("--pinned-depth", "on"));
  EXPECT_FALSE(OnOff("--pinned-depth", "off"));
  EXPECT_EQ(Refusal([] { OnOff("--pinned-depth", "yes"); }),
            "--pinned-depth takes on or off, got 'yes'");
  for (const char* text : {"", "On", "1", "true", " on", "off "})
    EXPECT_NE(Refusal([&] { OnOff("--pinned-depth", text); }), "") << "'" << text << "'";
}

}  // namespace
}  // namespace dfsm
