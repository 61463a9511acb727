#include "core/pipeline/burst_length.h"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/io/burst.h"
#include "core/pipeline/frame_selection.h"
#include "core/pipeline/pipeline.h"

namespace dfsm {
namespace {

void Require(bool holds, const std::string& what) {
  if (!holds) throw std::invalid_argument(what);
}

// The parallax the pipeline's sparse stage measures on `burst`: its trial.
BurstLengthTrial Try(const Burst& burst, const PipelineOptions& pipeline) {
  const Result result = RunPipeline(burst, SparseStageOf(pipeline)).result;
  BurstLengthTrial trial;
  trial.frames = burst.size();
  if (result.ok)
    trial.parallax_px = result.extra.at("parallax").at("median_px").get<double>();
  else
    trial.error = result.error;
  return trial;
}

}  // namespace

void BurstLengthOptions::Check() const {
  Require(!lengths.empty(), "burst length: lengths must not be empty");
  Require(lengths.front() >= 3, "burst length: lengths must be at least 3 frames");
  Require(std::is_sorted(lengths.begin(), lengths.end()),
          "burst length: lengths must be ascending");
  Require(target_parallax_px > 0.0, "burst length: target_parallax_px must be > 0");
  Require(min_parallax_px >= 0.0 && min_parallax_px <= target_parallax_px,
          "burst length: min_parallax_px must be in [0, target_parallax_px]");
}

const char* BurstLengthReasonName(BurstLengthReason reason) {
  switch (reason) {
    case BurstLengthReason::kParallaxReached:
      return "parallax reached";
    case BurstLengthReason::kAllFrames:
      return "all frames";
    case BurstLengthReason::kTooStill:
      return "too still";
  }
  return "unknown";
}

Burst FramesFromReference(const Burst& burst, int frames) {
  const int all = burst.size();
  if (frames < 3 || frames > all)
    throw std::invalid_argument("FramesFromReference: " + std::to_string(frames) + " of " +
                                std::to_string(all) + " frames");
  const int first = std::clamp(burst.reference() - (frames - 1) / 2, 0, all - frames);
  std::vector<int> kept(frames);
  for (int i = 0; i < frames; ++i) kept[i] = first + i;
  return SelectFrames(burst, kept);
}

BurstLength ChooseBurstLength(const Burst& burst, const PipelineOptions& pipeline,
                              const BurstLengthOptions& options, const ProgressCallback& progress) {
  options.Check();
  std::vector<int> lengths;
  for (const int frames : options.lengths)
    if (frames < burst.size()) lengths.push_back(frames);
  lengths.push_back(burst.size());
  BurstLength length;
  for (const int frames : lengths) {
    length.trials.push_back(Try(FramesFromReference(burst, frames), pipeline));
    ReportProgress(progress, kBurstLengthLap, static_cast<int>(length.trials.size()),
                   static_cast<int>(lengths.size()));
    const BurstLengthTrial& trial = length.trials.back();
    length.frames = frames;
    length.parallax_px = trial.parallax_px;
    if (trial.parallax_px >= options.target_parallax_px) {
      length.reason = BurstLengthReason::kParallaxReached;
      return length;
    }
  }
  // A burst whose last trial failed is not called still: its own run says why.
  const bool failed = !length.trials.back().error.empty();
  length.reason = !failed && length.parallax_px < options.min_parallax_px
                      ? BurstLengthReason::kTooStill
                      : BurstLengthReason::kAllFrames;
  return length;
}

nlohmann::json ToJson(const BurstLength& length, int frames_available,
                      const BurstLengthOptions& options) {
  nlohmann::json trials = nlohmann::json::array();
  for (const BurstLengthTrial& trial : length.trials) {
    nlohmann::json entry = {{"frames", trial.frames}, {"parallax_px", trial.parallax_px}};
    if (!trial.error.empty()) entry["error"] = trial.error;
    trials.push_back(entry);
  }
  return {{"frames", length.frames},
          {"of", frames_available},
          {"parallax_px", length.parallax_px},
          {"target_parallax_px", options.target_parallax_px},
          {"reason", BurstLengthReasonName(length.reason)},
          {"trials", trials}};
}

}  // namespace dfsm
