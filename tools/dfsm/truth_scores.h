// A result scored against the ground truth of the synthetic burst it was made
// from: `dfsm evaluate` prints every metric, `dfsm batch` and `dfsm show` a
// summary of the same reading.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>

#include "core/io/burst.h"
#include "core/io/ground_truth.h"
#include "core/pipeline/evaluation.h"

namespace dfsm::tools {

struct TruthScores {
  GroundTruth truth;
  SparseEvaluation sparse;  // of the result's calibration and poses
  // Where the result has a depth map: the burst (for its reference frame),
  // the map, the reference's textured pixels and the map scored on them.
  std::optional<Burst> burst;
  cv::Mat depth_map;
  cv::Mat textured;
  std::optional<DepthEvaluation> depth;
};

// Scores `result` (result_dir's result.json, status ok) against the burst
// directory `burst_dir`, which holds ground_truth.json. Throws
// std::runtime_error (or BurstError) naming a file that cannot be read.
TruthScores ScoreAgainstTruth(const std::filesystem::path& burst_dir,
                              const std::filesystem::path& result_dir,
                              const nlohmann::json& result);

}  // namespace dfsm::tools
