#include "tools/dfsm/batch_calibration.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <map>

#include "core/export/calibration_export.h"
#include "core/io/file_util.h"
#include "core/sparse/calibration_choice.h"
#include "core/sparse/calibration_fusion.h"
#include "core/sparse/joint_adjustment.h"

namespace dfsm::tools {
namespace fs = std::filesystem;
namespace {

// The prior joint.json gives every burst, or nullopt with why.
std::optional<KnownCalibration> PriorOf(const nlohmann::json& joint, std::string* said) {
  std::optional<KnownCalibration> known = JointCalibrationPrior(joint, said);
  if (!known) {
    *said += "; each burst calibrates itself";
    return std::nullopt;
  }
  known->also_self_calibrate = false;  // no fusion takes the bursts' own estimates
  char line[240];
  std::snprintf(line, sizeof line,
                "joint calibration of %d bursts (%s, answered by the %s camera): f %.2f px "
                "(sigma %.2f %%); a prior of every burst, checked against it",
                joint.at("bursts_joined").get<int>(),
                joint.at("verdict").value("quality", "").c_str(),
                joint.contains("answer") ? joint.at("answer").value("method", "").c_str() : "joint",
                known->camera.f, known->f_sigma_percent);
  *said = line;
  return known;
}

// One item's part in the joint calibration: its tracks and, where it
// calibrated itself, its sample for the fusion beside it.
struct BurstToJoin {
  JointBurst burst;
  std::optional<CalibrationSample> sample;
};

// Each item's sparse stage alone, of the image size most items have; the
// fusion of their own estimates goes to `fusion`.
std::vector<JointBurst> BurstsToJoin(const std::vector<BatchItem>& items,
                                     const BatchRunOptions& options,
                                     const PipelineOptions& pipeline, CalibrationFusion* fusion) {
  std::vector<BurstToJoin> joining;
  std::map<std::pair<int, int>, int> sizes;
  for (const BatchItem& item : items) {
    // Shards calibrating at once each read into scratch of their own.
    const fs::path scratch = options.out_dir / ".partial" /
                             (".calibration-" + std::to_string(getpid()) + "-" + item.name);
    try {
      const SparseReconstruction own =
          ReconstructAlone(item, options.process.frames, pipeline, scratch);
      ++sizes[{own.state.camera.width, own.state.camera.height}];
      std::string not_fused;
      joining.push_back({JointBurstOf(item.name, own), FusionSampleOf(own, item.name, &not_fused)});
    } catch (const BurstError& e) {
      std::fprintf(stderr, "dfsm batch: %s: not joined: %s\n", item.name.c_str(), e.what());
    } catch (const ReconstructionError& e) {
      std::fprintf(stderr, "dfsm batch: %s: not joined: %s\n", item.name.c_str(), e.what());
    }
  }
  if (sizes.size() > 1) {
    const auto most =
        std::max_element(sizes.begin(), sizes.end(),
                         [](const auto& a, const auto& b) { return a.second < b.second; });
    joining.erase(std::remove_if(joining.begin(), joining.end(),
                                 [&](const BurstToJoin& item) {
                                   const CameraModel& camera = item.burst.state.camera;
                                   return std::make_pair(camera.width, camera.height) !=
                                          most->first;
                                 }),
                  joining.end());
    std::fprintf(stderr, "dfsm batch: bursts of several image sizes: %dx%d (%d bursts) joined\n",
                 most->first.first, most->first.second, most->second);
  }
  std::vector<JointBurst> bursts;
  for (BurstToJoin& item : joining) {
    if (item.sample) fusion->Add(*item.sample);
    bursts.push_back(std::move(item.burst));
  }
  return bursts;
}

}  // namespace

SparseReconstruction ReconstructAlone(const BatchItem& item, int max_frames,
                                      const PipelineOptions& pipeline, const fs::path& scratch) {
  struct Scratch {
    const fs::path& dir;
    ~Scratch() {
      std::error_code error;
      fs::remove_all(dir, error);
    }
  } removed_after{scratch};
  fs::path burst_dir;
  const Burst burst = ReadBatchItem(item, max_frames, scratch, &burst_dir);
  return ReconstructSparseStage(burst, pipeline);
}

std::optional<KnownCalibration> CalibrateFirst(const std::vector<BatchItem>& items,
                                               const BatchRunOptions& options, std::string* said) {
  const fs::path dir = options.out_dir / "calibration";
  std::error_code error;
  if (fs::is_regular_file(dir / "joint.json", error))
    return PriorOf(nlohmann::json::parse(ReadFileToString(dir / "joint.json")), said);
  const PipelineOptions pipeline = ParsedPipelineOptions(options.process);
  CalibrationFusion fusion;
  const std::vector<JointBurst> bursts = BurstsToJoin(items, options, pipeline, &fusion);
  if (bursts.empty()) {
    *said = "no burst could be calibrated; each burst calibrates itself";
    return std::nullopt;
  }
  JointCalibration joint;
  try {
    joint = AdjustJointly(bursts, JointOptionsFor(pipeline.sparse));
  } catch (const ReconstructionError& e) {
    *said = std::string("no joint calibration (") + e.what() + "); each burst calibrates itself";
    return std::nullopt;
  }
  const Answer answer = ChooseAnswer(joint, fusion);
  nlohmann::json json = ToJson(joint, bursts);
  json["answer"] = ToJson(answer);
  fs::create_directories(dir);
  WriteCalibrationFiles(dir, answer.camera);
  WriteFileAtomically(dir / "joint.json", json.dump(2) + "\n");
  return PriorOf(json, said);
}

}  // namespace dfsm::tools
