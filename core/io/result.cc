#include "core/io/result.h"

#include "core/io/file_util.h"

namespace dfsm {

nlohmann::json ToJson(const Result& result) {
  nlohmann::json j = result.extra.is_object() ? result.extra : nlohmann::json::object();
  j["format"] = kResultFormat;
  j["status"] = result.ok ? "ok" : "failed";
  if (!result.ok) j["error"] = result.error;
  j["warnings"] = result.warnings;
  nlohmann::json timings = nlohmann::json::object();
  for (const auto& [stage, ms] : result.timings_ms) timings[stage] = ms;
  j["timings_ms"] = timings;
  if (!result.ok && result.poses.empty()) return j;

  j["calibration"] = ToJson(result.calibration);
  if (result.calibration_detail.is_object())
    for (const auto& [key, value] : result.calibration_detail.items())
      j["calibration"][key] = value;
  nlohmann::json poses = nlohmann::json::array();
  for (const Pose& pose : result.poses) poses.push_back(ToJson(pose));
  j["poses"] = poses;
  const BundleAdjustmentSummary& ba = result.bundle_adjustment;
  j["bundle_adjustment"] = {{"init", ba.init},
                            {"iterations", ba.iterations},
                            {"converged", ba.converged},
                            {"initial_cost", ba.initial_cost},
                            {"final_cost", ba.final_cost},
                            {"rms_reprojection_px", ba.rms_reprojection_px},
                            {"termination", ba.termination},
                            {"start_f_px", ba.start_f},
                            {"from_self_calibration", ba.from_self_calibration}};
  nlohmann::json runs = nlohmann::json::array();
  for (const BundleAdjustmentRun& run : ba.runs)
    runs.push_back({{"iterations", run.iterations},
                    {"converged", run.converged},
                    {"tracks", run.tracks},
                    {"final_cost", run.final_cost}});
  j["bundle_adjustment"]["runs"] = runs;
  j["sparse"] = {{"features", result.features}, {"features_detected", result.features_detected}};
  if (result.depth) {
    const DepthSummary& depth = *result.depth;
    j["depth"] = {{"file", depth.file},
                  {"valid_fraction", depth.valid_fraction},
                  {"planes", depth.planes},
                  {"min_inverse_depth", depth.min_inverse_depth},
                  {"max_inverse_depth", depth.max_inverse_depth}};
  }
  return j;
}

void WriteResultJson(const std::filesystem::path& out_dir, const Result& result) {
  std::filesystem::create_directories(out_dir);
  WriteFileAtomically(out_dir / "result.json", ToJson(result).dump(2) + "\n");
}

}  // namespace dfsm
