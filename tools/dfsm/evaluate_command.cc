// dfsm evaluate --result DIR --truth BURST: scores a result against the ground
// truth of a synthetic burst and prints the metrics as JSON.
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "core/io/burst.h"
#include "core/io/depth_tiff.h"
#include "core/io/file_util.h"
#include "core/pipeline/evaluation.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"

namespace dfsm::tools {

int RunEvaluateCommand(const Args& args) {
  CLI::App app("Compares a result against a synthetic burst's ground truth; prints JSON.",
               "dfsm evaluate");
  std::filesystem::path result_dir, burst_dir;
  app.add_option("--result", result_dir, "a dfsm-result/1 directory")->required();
  app.add_option("--truth", burst_dir, "the synthetic burst (dfsm synth) it was made from")
      ->required();
  if (const auto status = ParseCommandLine(app, args)) return *status;

  const nlohmann::json result = nlohmann::json::parse(ReadFileToString(result_dir / "result.json"));
  if (result.value("status", "") != "ok")
    throw std::runtime_error(result_dir.string() + ": result status is not ok");
  const GroundTruth truth = ReadGroundTruth(burst_dir);
  std::vector<Pose> poses;
  for (const auto& pose : result.at("poses")) poses.push_back(PoseFromJson(pose));
  nlohmann::json report = {
      {"sparse",
       ToJson(EvaluateSparse(CameraModelFromJson(result.at("calibration")), poses, truth))},
      {"bundle_adjustment", result.at("bundle_adjustment")}};
  if (result.contains("depth")) {
    const Burst burst = ReadBurst(burst_dir);
    const cv::Mat depth = ReadDepthTiff(result_dir / result["depth"].value("file", "depth.tiff"));
    report["depth"] =
        ToJson(EvaluateDepth(depth, truth.depth, TexturedMask(burst.gray[burst.reference()])));
  }
  std::cout << report.dump(2) << std::endl;
  return 0;
}

}  // namespace dfsm::tools
