// Two runs of one report program (tum_benchmark, depth_sweep,
// calibration_sweep: one JSON object per line) compared item by item. A real
// witness such as TUM fr1/rpy moves a window's error by tens of percent for
// small causes, so a change is judged by how many items it makes better and
// worse and by their ratios, not by one median
// (docs/experiments/031-rpy-depth-under-camera-errors.md).
#pragma once

#include <istream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace dfsm {

struct ReportComparisonOptions {
  // The figure compared, a path of object keys ("depth.abs_rel",
  // "f_error_percent"); its magnitude is compared (an f error's sign says
  // only its side).
  std::string metric = "depth.abs_rel";
  // An item is better where after / before < 1 - tolerance, worse where it
  // is > 1 + tolerance.
  double tolerance = 0.1;

  // Throws std::invalid_argument naming the option.
  void Check() const;
};

// One item found in both runs.
struct ComparedItem {
  std::string key;
  double before = 0.0;
  double after = 0.0;
  double ratio = 0.0;  // after / before (magnitudes)
};

struct ReportComparison {
  std::vector<ComparedItem> items;  // in key order
  int better = 0;
  int worse = 0;
  double median_ratio = 0.0;             // WindowMedian (0 where none compared)
  double geometric_mean_ratio = 0.0;     // 0 where no item compared
  std::vector<std::string> only_before;  // an item the later run lost
  std::vector<std::string> only_after;   // an item only the later run has
  // Items whose figure was 0 before and is not after: no ratio to take.
  std::vector<std::string> from_zero;
};

// The key of one report line: its window and mode (tum_benchmark: "first",
// "mode") or its burst ("seed", with "mode" where present); empty where the
// line is no item (a summary, a header) or lacks the metric.
std::string ReportItemKey(const nlohmann::json& line);

// The items of a report: every line that parses as a JSON object with a key
// and the metric (other lines, tables and summaries, are passed over).
// Throws std::invalid_argument where two lines share a key.
std::map<std::string, double> ReadReportItems(std::istream& in,
                                              const ReportComparisonOptions& options);

ReportComparison CompareReports(const std::map<std::string, double>& before,
                                const std::map<std::string, double>& after,
                                const ReportComparisonOptions& options);

nlohmann::json ToJson(const ReportComparison& comparison);

}  // namespace dfsm
