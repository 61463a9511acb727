// dfsm evaluate --result DIR --truth BURST: scores a result against the ground
// truth of a synthetic burst and prints the metrics as JSON.
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "core/io/file_util.h"
#include "core/io/image_decode.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"
#include "tools/dfsm/truth_scores.h"

namespace dfsm::tools {

namespace {

// The depth of a burst with a moving object (dfsm synth --moving-object),
// scored with the whole map's scale on three sets of textured pixels: where
// the object is in the reference (`object`: the truth shows it there), where
// it passes in another frame only (`swept`: the background there is hidden
// from some frames), and everywhere else (`elsewhere`). The masks are the
// files ground_truth.json's moving_object.frames name, one per frame.
nlohmann::json EvaluateAroundMovingObject(const std::filesystem::path& burst_dir,
                                          const nlohmann::json& frames, const Burst& burst,
                                          const cv::Mat& depth, const GroundTruth& truth,
                                          const cv::Mat& textured, double scale) {
  if (!frames.is_array() || static_cast<int>(frames.size()) != burst.size())
    throw std::runtime_error((burst_dir / "ground_truth.json").string() +
                             ": moving_object.frames must list one mask per frame");
  cv::Mat reference_mask, any_mask = cv::Mat::zeros(depth.size(), CV_8UC1);
  for (int i = 0; i < burst.size(); ++i) {
    const std::filesystem::path file = burst_dir / frames[i].at("mask").get<std::string>();
    cv::Mat mask;
    try {
      mask = ToGray8(ReadImageFile(file));
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(std::string(e.what()) + " (a moving-object mask)");
    }
    if (mask.size() != depth.size())
      throw std::runtime_error(file.string() + ": not a mask of the burst's size");
    any_mask |= mask;
    if (i == burst.reference()) reference_mask = mask;
  }
  const cv::Mat swept = any_mask & ~reference_mask;
  const cv::Mat elsewhere = ~any_mask;
  return {{"object", ToJson(EvaluateDepth(depth, truth.depth, textured & reference_mask, scale))},
          {"swept", ToJson(EvaluateDepth(depth, truth.depth, textured & swept, scale))},
          {"elsewhere", ToJson(EvaluateDepth(depth, truth.depth, textured & elsewhere, scale))},
          {"object_pixels", cv::countNonZero(reference_mask)},
          {"swept_pixels", cv::countNonZero(swept)}};
}

}  // namespace

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
  const TruthScores scores = ScoreAgainstTruth(burst_dir, result_dir, result);
  nlohmann::json report = {{"sparse", ToJson(scores.sparse)},
                           {"bundle_adjustment", result.at("bundle_adjustment")}};
  if (scores.depth) {
    report["depth"] = ToJson(*scores.depth);
    const nlohmann::json truth_json =
        nlohmann::json::parse(ReadFileToString(burst_dir / "ground_truth.json"));
    if (truth_json.contains("moving_object"))
      report["moving_object"] = EvaluateAroundMovingObject(
          burst_dir, truth_json["moving_object"].at("frames"), *scores.burst, scores.depth_map,
          scores.truth, scores.textured, scores.depth->scale);
  }
  std::cout << report.dump(2) << std::endl;
  return 0;
}

}  // namespace dfsm::tools
