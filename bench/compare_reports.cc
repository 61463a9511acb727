// compare_reports BEFORE AFTER [--metric PATH] [--tolerance T]: two runs of a
// report program (tum_benchmark, depth_sweep, calibration_sweep) item by item,
// as one JSON object: how many items are better and worse, the median and
// geometric mean of their ratios, each item's figures, and the items one run
// lacks (bench/report_comparison.h). Exit status 0, or 2 for a usage error or
// a report that cannot be read.
#include <fstream>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/report_comparison.h"
#include "bench/report_options.h"

namespace {

constexpr const char* kUsage =
    "usage: compare_reports BEFORE AFTER [--metric PATH] [--tolerance T]\n"
    "  BEFORE, AFTER: the JSON lines of two runs of one report program\n"
    "  --metric: the figure compared (default depth.abs_rel; calibration_sweep: "
    "f_error_percent)\n"
    "  --tolerance: an item is better or worse where its ratio leaves 1 by more (default 0.1)\n";

std::map<std::string, double> ReadReport(const std::string& path,
                                         const dfsm::ReportComparisonOptions& options) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("cannot read the report " + path);
  std::map<std::string, double> items = dfsm::ReadReportItems(in, options);
  if (items.empty())
    throw std::invalid_argument("the report " + path + " has no line with an item and " +
                                options.metric);
  return items;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    dfsm::ReportComparisonOptions options;
    std::vector<std::string> paths;
    for (int i = 1; i < argc; ++i) {
      const std::string argument = argv[i];
      if (argument == "--help") {
        std::cout << kUsage;
        return 0;
      }
      if (argument.rfind("--", 0) != 0) {
        paths.push_back(argument);
        continue;
      }
      if (i + 1 >= argc) throw std::invalid_argument(argument + " needs a value");
      const std::string value = argv[++i];
      if (argument == "--metric")
        options.metric = value;
      else if (argument == "--tolerance")
        options.tolerance = dfsm::NonNegativeNumber("--tolerance", value);
      else
        throw std::invalid_argument("unknown option " + argument);
    }
    if (paths.size() != 2)
      throw std::invalid_argument("two reports are compared, got " + std::to_string(paths.size()));
    options.Check();
    const auto before = ReadReport(paths[0], options);
    const auto after = ReadReport(paths[1], options);
    std::cout << dfsm::ToJson(dfsm::CompareReports(before, after, options)).dump() << "\n";
    return 0;
  } catch (const std::exception& error) {
    std::cerr << "compare_reports: " << error.what() << "\n" << kUsage;
    return 2;
  }
}
