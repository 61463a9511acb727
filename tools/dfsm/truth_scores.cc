#include "tools/dfsm/truth_scores.h"

#include <vector>

#include "core/io/depth_tiff.h"

namespace dfsm::tools {

TruthScores ScoreAgainstTruth(const std::filesystem::path& burst_dir,
                              const std::filesystem::path& result_dir,
                              const nlohmann::json& result) {
  TruthScores scores;
  scores.truth = ReadGroundTruth(burst_dir);
  std::vector<Pose> poses;
  for (const auto& pose : result.at("poses")) poses.push_back(PoseFromJson(pose));
  scores.sparse =
      EvaluateSparse(CameraModelFromJson(result.at("calibration")), poses, scores.truth);
  if (!result.contains("depth")) return scores;
  scores.burst = ReadBurst(burst_dir);
  scores.depth_map = ReadDepthTiff(result_dir / result["depth"].value("file", "depth.tiff"));
  scores.textured = TexturedMask(scores.burst->gray[scores.burst->reference()]);
  scores.depth = EvaluateDepth(scores.depth_map, scores.truth.depth, scores.textured);
  return scores;
}

}  // namespace dfsm::tools
