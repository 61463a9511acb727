// dfsm show RESULT [--truth BURST]: a result directory in a few lines for a
// person (the camera with its sigma and verdict, the depth's range, cover and
// verdict, the warnings, the time, the files), with the scores against a
// synthetic burst's ground truth where one is given.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/io/file_util.h"
#include "tools/dfsm/batch_summary.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"

namespace dfsm::tools {
namespace {

namespace fs = std::filesystem;

void PrintCalibration(const nlohmann::json& calibration) {
  const nlohmann::json uncertainty = calibration.value("uncertainty", nlohmann::json::object());
  std::printf("calibration f %.2f px", calibration.value("fx", 0.0));
  if (uncertainty.value("available", false))
    std::printf(" (sigma %.2f %%)", uncertainty.value("sigma_f_percent", 0.0));
  std::printf(", k1 %.5f, k2 %.5f: %s (%s)\n", calibration.value("k1", 0.0),
              calibration.value("k2", 0.0), calibration.value("quality", "").c_str(),
              calibration.value("source", "").c_str());
}

void PrintDepth(const nlohmann::json& result) {
  if (!result.contains("depth")) {
    std::printf("depth       none (sparse stage only)\n");
    return;
  }
  const nlohmann::json& depth = result["depth"];
  const double near = depth.value("max_inverse_depth", 0.0);
  const double far = depth.value("min_inverse_depth", 0.0);
  std::printf("depth       %.3g to %.3g (the burst's scale), %.1f %% of the pixels",
              near > 0.0 ? 1.0 / near : 0.0, far > 0.0 ? 1.0 / far : 0.0,
              100.0 * depth.value("valid_fraction", 0.0));
  if (result.contains("depth_verdict"))
    std::printf(": %s", result["depth_verdict"].value("quality", "").c_str());
  std::printf("\n");
}

void PrintScores(const nlohmann::json& scores) {
  if (scores.is_null()) {
    std::printf("scores      none: the burst has no ground_truth.json\n");
    return;
  }
  std::printf("scores      f %+.2f %%", scores.value("f_error_percent", 0.0));
  if (scores.contains("abs_rel"))
    std::printf(", depth AbsRel %.2f %% (%.1f %% of the pixels within 25 %%)",
                100.0 * scores.value("abs_rel", 0.0),
                100.0 * scores.value("within_25_percent", 0.0));
  std::printf(", against the ground truth\n");
}

}  // namespace

int RunShowCommand(const Args& args) {
  CLI::App app("Shows a result directory in a few lines: camera, depth, warnings, time, files.",
               "dfsm show");
  app.footer(
      "Exit status: 0 the result is ok, 1 it failed (the reason is shown) or is unreadable, "
      "2 usage.");
  std::string result_dir, truth;
  app.add_option("RESULT", result_dir, "a dfsm-result/1 directory")->required();
  app.add_option("--truth", truth, "the synthetic burst it was made from: adds the scores");
  if (const auto status = ParseCommandLine(app, args)) return *status;

  const nlohmann::json result =
      nlohmann::json::parse(ReadFileToString(fs::path(result_dir) / "result.json"));
  const nlohmann::json input = result.value("input", nlohmann::json::object());
  const std::string status = result.value("status", "failed");
  std::printf("result      %s: %s, %d frames %dx%d\n", result_dir.c_str(), status.c_str(),
              input.value("frames", 0), input.value("width", 0), input.value("height", 0));
  if (status != "ok") {
    std::printf("error       %s\n", result.value("error", "").c_str());
    return 1;
  }
  PrintCalibration(result.at("calibration"));
  PrintDepth(result);
  const nlohmann::json warnings = result.value("warnings", nlohmann::json::array());
  for (const auto& warning : warnings)
    std::printf("warning     %s\n", warning.get<std::string>().c_str());
  const nlohmann::json timings = result.value("timings_ms", nlohmann::json::object());
  std::printf("time        %.2f s in the pipeline\n", timings.value("total", 0.0) / 1000.0);
  if (!truth.empty()) {
    try {
      PrintScores(ScoresAgainstTruth(truth, result_dir));
    } catch (const std::exception& e) {  // the result stands without them
      std::printf("scores      unavailable: %s\n", e.what());
    }
  }
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(result_dir))
    if (entry.is_regular_file()) files.push_back(entry.path().filename().string());
  std::sort(files.begin(), files.end());
  std::printf("files      ");
  for (const std::string& file : files) std::printf(" %s", file.c_str());
  std::printf("\n");
  return 0;
}

}  // namespace dfsm::tools
