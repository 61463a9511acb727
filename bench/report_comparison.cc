#include "bench/report_comparison.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "bench/tum_sequence.h"

namespace dfsm {

void ReportComparisonOptions::Check() const {
  if (metric.empty()) throw std::invalid_argument("--metric must name a figure, got nothing");
  if (!(tolerance >= 0.0 && tolerance < 1.0)) {
    std::ostringstream text;
    text << "--tolerance must be at least 0 and below 1, got " << tolerance;
    throw std::invalid_argument(text.str());
  }
}

namespace {

// The number at `path` ("a.b.c") in `line`, or NaN where there is none.
double MetricAt(const nlohmann::json& line, const std::string& path) {
  const nlohmann::json* node = &line;
  std::istringstream parts(path);
  for (std::string part; std::getline(parts, part, '.');) {
    if (!node->is_object() || !node->contains(part)) return std::nan("");
    node = &(*node)[part];
  }
  return node->is_number() ? node->get<double>() : std::nan("");
}

}  // namespace

std::string ReportItemKey(const nlohmann::json& line) {
  if (!line.is_object()) return "";
  const std::string mode =
      line.contains("mode") && line["mode"].is_string() ? line["mode"].get<std::string>() : "";
  const auto with_mode = [&](const std::string& item) {
    return mode.empty() ? item : item + " " + mode;
  };
  if (line.contains("first") && line["first"].is_number_integer())
    return with_mode("window " + std::to_string(line["first"].get<long>()));
  if (line.contains("seed") && line["seed"].is_number_integer())
    return with_mode("seed " + std::to_string(line["seed"].get<long>()));
  return "";
}

std::map<std::string, double> ReadReportItems(std::istream& in,
                                              const ReportComparisonOptions& options) {
  std::map<std::string, double> items;
  for (std::string text; std::getline(in, text);) {
    if (text.empty() || text.front() != '{') continue;
    const nlohmann::json line = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    const std::string key = ReportItemKey(line);
    const double value = MetricAt(line, options.metric);
    if (key.empty() || !std::isfinite(value)) continue;
    if (!items.emplace(key, std::abs(value)).second)
      throw std::invalid_argument("two report lines for " + key);
  }
  return items;
}

ReportComparison CompareReports(const std::map<std::string, double>& before,
                                const std::map<std::string, double>& after,
                                const ReportComparisonOptions& options) {
  ReportComparison comparison;
  std::vector<double> ratios;
  double log_sum = 0.0;
  for (const auto& [key, was] : before) {
    const auto found = after.find(key);
    if (found == after.end()) {
      comparison.only_before.push_back(key);
      continue;
    }
    const double now = found->second;
    if (!(was > 0.0) && now > 0.0) {
      comparison.from_zero.push_back(key);
      continue;
    }
    ComparedItem item{key, was, now, was > 0.0 ? now / was : 1.0};
    comparison.better += item.ratio < 1.0 - options.tolerance;
    comparison.worse += item.ratio > 1.0 + options.tolerance;
    ratios.push_back(item.ratio);
    log_sum += std::log(std::max(item.ratio, 1e-300));
    comparison.items.push_back(item);
  }
  for (const auto& [key, value] : after)
    if (!before.count(key)) comparison.only_after.push_back(key);
  comparison.median_ratio = WindowMedian(ratios);
  if (!ratios.empty()) comparison.geometric_mean_ratio = std::exp(log_sum / ratios.size());
  return comparison;
}

nlohmann::json ToJson(const ReportComparison& comparison) {
  nlohmann::json moved = nlohmann::json::array();
  for (const ComparedItem& item : comparison.items)
    moved.push_back({{"item", item.key},
                     {"before", item.before},
                     {"after", item.after},
                     {"ratio", item.ratio}});
  return {{"compared", comparison.items.size()},
          {"better", comparison.better},
          {"worse", comparison.worse},
          {"median_ratio", comparison.median_ratio},
          {"geometric_mean_ratio", comparison.geometric_mean_ratio},
          {"only_before", comparison.only_before},
          {"only_after", comparison.only_after},
          {"from_zero", comparison.from_zero},
          {"items", moved}};
}

}  // namespace dfsm
