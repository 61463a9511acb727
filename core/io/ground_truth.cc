#include "core/io/ground_truth.h"

#include <nlohmann/json.hpp>

#include "core/io/depth_tiff.h"
#include "core/io/file_util.h"

namespace dfsm {
namespace fs = std::filesystem;

bool HasGroundTruth(const fs::path& burst_dir) {
  std::error_code ec;
  return fs::is_regular_file(burst_dir / "ground_truth.json", ec);
}

GroundTruth ReadGroundTruth(const fs::path& burst_dir) {
  const fs::path path = burst_dir / "ground_truth.json";
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(ReadFileToString(path));
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
  GroundTruth truth;
  try {
    truth.camera = CameraModelFromJson(j);
    if (!j.contains("poses") || !j["poses"].is_array())
      throw std::runtime_error("'poses' missing or not an array");
    for (const auto& pose : j["poses"]) truth.poses.push_back(PoseFromJson(pose));
    truth.depth_file = j.value("depth", std::string("depth_gt.tiff"));
  } catch (const std::exception& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
  if (!IsLexicallyInside(burst_dir, burst_dir / truth.depth_file))
    throw std::runtime_error(path.string() + ": 'depth' lies outside the burst directory");
  truth.depth = ReadDepthTiff(burst_dir / truth.depth_file);
  if (truth.depth.cols != truth.camera.width || truth.depth.rows != truth.camera.height)
    throw std::runtime_error(path.string() + ": depth map size differs from the calibration");
  return truth;
}

void WriteGroundTruth(const fs::path& burst_dir, const GroundTruth& truth) {
  nlohmann::json j = ToJson(truth.camera);
  nlohmann::json poses = nlohmann::json::array();
  for (const Pose& pose : truth.poses) poses.push_back(ToJson(pose));
  j["poses"] = poses;
  j["depth"] = truth.depth_file;
  WriteDepthTiff(burst_dir / truth.depth_file, truth.depth);
  WriteFileAtomically(burst_dir / "ground_truth.json", j.dump(2) + "\n");
}

}  // namespace dfsm
