#include "bench/report_comparison.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace dfsm {
namespace {

std::map<std::string, double> Items(const std::string& text,
                                    const ReportComparisonOptions& options = {}) {
  std::istringstream in(text);
  return ReadReportItems(in, options);
}

TEST(ReportComparison, ReadsWindowsAndBurstsAndPassesOverTheRest) {
  const std::string tum =
      "# calibration bench/data/tum_freiburg1.yaml\n"
      "{\"first\":0,\"mode\":\"known\",\"depth\":{\"abs_rel\":0.18}}\n"
      "{\"first\":0,\"mode\":\"self\",\"depth\":{\"abs_rel\":0.25}}\n"
      "{\"first\":12,\"mode\":\"self\",\"error\":\"too few tracks\"}\n"
      "| window | mode |\n"
      "median, known: 1 of 1 windows\n";
  const auto items = Items(tum);
  ASSERT_EQ(items.size(), 2u);
  EXPECT_DOUBLE_EQ(items.at("window 0 known"), 0.18);
  EXPECT_DOUBLE_EQ(items.at("window 0 self"), 0.25);

  ReportComparisonOptions calibration;
  calibration.metric = "f_error_percent";
  const auto bursts = Items("{\"seed\":3000,\"f_error_percent\":-2.5}\n", calibration);
  EXPECT_DOUBLE_EQ(bursts.at("seed 3000"), 2.5);  // the magnitude
}

TEST(ReportComparison, TwoLinesForOneItemAreRefused) {
  try {
    Items("{\"seed\":1,\"depth\":{\"abs_rel\":0.1}}\n{\"seed\":1,\"depth\":{\"abs_rel\":0.2}}\n");
    FAIL() << "a repeated item was taken";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "two report lines for seed 1");
  }
}

TEST(ReportComparison, CountsBetterAndWorseAndNamesWhatOneRunLacks) {
  const std::map<std::string, double> before = {{"a", 0.10}, {"b", 0.20},   {"c", 0.40},
                                                {"d", 0.30}, {"lost", 0.5}, {"zero", 0.0}};
  const std::map<std::string, double> after = {{"a", 0.05}, {"b", 0.21},  {"c", 0.80},
                                               {"d", 0.30}, {"new", 0.1}, {"zero", 0.2}};
  const ReportComparison comparison = CompareReports(before, after, {});
  ASSERT_EQ(comparison.items.size(), 4u);
  EXPECT_EQ(comparison.better, 1);  // a: 0.5x
  EXPECT_EQ(comparison.worse, 1);   // c: 2x; b (1.05x) is within the tolerance
  // Ratios 0.5, 1.05, 2, 1: median (1 + 1.05) / 2, geometric mean (1.05)^(1/4).
  EXPECT_NEAR(comparison.median_ratio, 1.025, 1e-12);
  EXPECT_NEAR(comparison.geometric_mean_ratio, std::pow(1.05, 0.25), 1e-12);
  EXPECT_EQ(comparison.only_before, std::vector<std::string>{"lost"});
  EXPECT_EQ(comparison.only_after, std::vector<std::string>{"new"});
  EXPECT_EQ(comparison.from_zero, std::vector<std::string>{"zero"});
  const nlohmann::json json = ToJson(comparison);
  EXPECT_EQ(json["compared"], 4);
  EXPECT_EQ(json["items"][2]["item"], "c");
  EXPECT_DOUBLE_EQ(json["items"][2]["ratio"].get<double>(), 2.0);
}

TEST(ReportComparison, OptionsAreChecked) {
  ReportComparisonOptions options;
  EXPECT_NO_THROW(options.Check());
  options.tolerance = 1.0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options.tolerance = 0.1;
  options.metric = "";
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
