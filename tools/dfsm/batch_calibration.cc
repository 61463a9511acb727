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

// Each item's sparse stage alone, of the image size most items have; the
// fusion of their own estimates goes to `fusion`.
std::vector<JointBurst> BurstsToJoin(const std::vector<BatchItem>& items,
                                     const BatchRunOptions& options,
                                     const PipelineOptions& pipeline, CalibrationFusion* fusion) {
  std::vector<JointBurst> bursts;
  std::vector<std::optional<CalibrationSample>> samples;  // each burst's
  std::map<std::pair<int, int>, int> sizes;
  for (const BatchItem& item : items) {
    // Shards calibrating at once each read into scratch of their own.
    const fs::path scratch = options.out_dir / ".partial" /
                             (".calibration-" + std::to_string(getpid()) + "-" + item.name);
    try {
      const SparseReconstruction own =
          ReconstructAlone(item, options.process.frames, pipeline, scratch);
      ++sizes[{own.state.camera.width, own.state.camera.height}];
      bursts.push_back(JointBurstOf(item.name, own));
      std::string not_fused;
      samples.push_back(FusionSampleOf(own, item.name, &not_fused));
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
    std::vector<JointBurst> kept;
    std::vector<std::optional<CalibrationSample>> kept_samples;
    for (size_t k = 0; k < bursts.size(); ++k) {
      if (std::make_pair(bursts[k].state.camera.width, bursts[k].state.camera.height) !=
          most->first)
        continue;
      kept.push_back(std::move(bursts[k]));
      kept_samples.push_back(std::move(samples[k]));
    }
    bursts = std::move(kept);
    samples = std::move(kept_samples);
    std::fprintf(stderr, "dfsm batch: bursts of several image sizes: %dx%d (%d bursts) joined\n",
                 most->first.first, most->first.second, most->second);
  }
  for (const std::optional<CalibrationSample>& sample : samples)
    if (sample) fusion->Add(*sample);
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
  nlohmann::json json = ToJson(joint, bursts);
  json["answer"] = AnswerJson(joint, fusion);
  fs::create_directories(dir);
  WriteCalibrationFiles(dir, AnsweredCamera(json));
  WriteFileAtomically(dir / "joint.json", json.dump(2) + "\n");
  return PriorOf(json, said);
}

}  // namespace dfsm::tools
