// The dfsm-result/1 summary, result.json (CONTRACT.md section 3).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"

namespace dfsm {

inline constexpr const char* kResultFormat = "dfsm-result/1";

// One run of the adjustment (the pipeline reruns it after dropping outliers).
struct BundleAdjustmentRun {
  int iterations = 0;
  bool converged = false;
  int tracks = 0;
  double final_cost = 0.0;
};

struct BundleAdjustmentSummary {
  // The start the solution came from: "rank1", or "naive" (SparseOptions::init,
  // or the naive probe where it won: SparseOptions::naive_probe).
  std::string init = "rank1";
  int iterations = 0;  // of the final run; every run is in `runs`
  std::vector<BundleAdjustmentRun> runs;
  bool converged = false;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  double rms_reprojection_px = 0.0;
  std::string termination;  // Ceres' own words, for people
  // The focal length (px) the chosen solution started from (SparseOptions::focal_starts).
  double start_f = 0.0;
  // Under a known calibration: the chosen solution started from the burst's
  // own, self-calibrated one, its camera replaced by the known one (`init`
  // is then how that one started).
  bool from_self_calibration = false;
};

struct DepthSummary {
  std::string file = "depth.tiff";
  double valid_fraction = 0.0;
  int planes = 0;
  double min_inverse_depth = 0.0;
  double max_inverse_depth = 0.0;
};

struct Result {
  bool ok = false;
  std::string error;  // when !ok
  CameraModel calibration;
  // Further members of "calibration" (uncertainty, quality, source), merged in.
  nlohmann::json calibration_detail = nlohmann::json::object();
  std::vector<Pose> poses;
  BundleAdjustmentSummary bundle_adjustment;
  int features = 0;           // tracks used by the sparse stage
  int features_detected = 0;  // corners before tracking and outlier rejection
  std::optional<DepthSummary> depth;
  std::vector<std::pair<std::string, double>> timings_ms;  // stage -> ms, in pipeline order
  // What the pipeline cannot vouch for: a calibration it replaced, a fallback
  // it took. Empty when nothing needs saying.
  std::vector<std::string> warnings;
  nlohmann::json extra = nlohmann::json::object();  // further fields, merged at the top level
};

nlohmann::json ToJson(const Result& result);
// Writes OUT/result.json atomically, creating OUT when needed.
void WriteResultJson(const std::filesystem::path& out_dir, const Result& result);

}  // namespace dfsm
