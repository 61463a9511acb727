// How long a burst must be: dfsmd's "frames": "auto" (core/pipeline/
// burst_length.h) against fixed lengths, on generated bursts with ground
// truth. A JSON report, not a timing benchmark: it sets BurstLengthOptions'
// defaults (docs/experiments/006-burst-length.md).
//
//   burst_length [--bursts N] [--seed S] [--camera ideal|webcam|phone]
//                [--frames M] [--motion-scale X] [--target PX] [--still PX]
//   burst_length --burst DIR [--target PX] [--still PX]
//
// Generated: the calibration sweep's bursts (sizes, tremor, effects), each
// rendered with M frames (30) and its camera path's extent and rotation
// times X (2: a hand drifts further over a second than over a third), the
// reference first (a capture of the next frames). Per burst: the pipeline's
// AbsRel and parallax for each length the choice tries and for all frames,
// and the length the choice takes. Then the median AbsRel of the choice, of
// 10 frames and of all, and the mean frames the choice takes. --burst: the
// choice on a burst directory (from its first frame where its reference is
// not an end), without truth.
#include "core/pipeline/burst_length.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "bench/report_options.h"
#include "bench/tum_sequence.h"
#include "core/pipeline/evaluation.h"
#include "core/pipeline/pipeline.h"
#include "core/synth/burst_synthesizer.h"
#include "tests/support/calibration_sweep.h"

namespace dfsm {
namespace {

struct Outcome {
  std::map<int, double> abs_rel;  // by frames; absent where the pipeline failed
  int chosen = 0;
  bool too_still = false;
};

// The pipeline on the first `frames` frames: AbsRel and parallax into `at`.
void RunLength(const Burst& burst, const GroundTruth& truth, int frames, Outcome* outcome,
               nlohmann::json* at) {
  const cv::Mat textured = TexturedMask(burst.gray[burst.reference()]);
  (*at)["frames"] = frames;
  try {
    const PipelineOutput output =
        RunPipeline(FramesFromReference(burst, frames), PipelineOptions());
    if (!output.dense) return;
    const double abs_rel = EvaluateDepth(output.dense->depth, truth.depth, textured).abs_rel;
    outcome->abs_rel[frames] = abs_rel;
    (*at)["abs_rel"] = abs_rel;
    (*at)["parallax_px"] =
        output.result.extra.value("parallax", nlohmann::json()).value("median_px", 0.0);
    (*at)["depth_verdict"] =
        output.result.extra.value("depth_verdict", nlohmann::json()).value("quality", "");
  } catch (const std::exception& e) {
    (*at)["error"] = e.what();
  }
}

Outcome RunGeneratedBurst(const SynthOptions& settings, const BurstLengthOptions& options) {
  const SynthBurst synth = SynthesizeBurst(settings);
  const Burst burst = ToBurst(synth);
  Outcome outcome;
  const BurstLength length = ChooseBurstLength(burst, PipelineOptions(), options);
  outcome.chosen = length.frames;
  outcome.too_still = length.reason == BurstLengthReason::kTooStill;
  nlohmann::json line = {{"width", settings.width},
                         {"height", settings.height},
                         {"baseline_mm", settings.baseline * 1000.0},
                         {"rotation_deg", settings.rotation_deg},
                         {"seed", settings.seed},
                         {"choice", ToJson(length, burst.size(), options)}};
  std::vector<int> lengths;
  for (const int frames : options.lengths)
    if (frames < burst.size()) lengths.push_back(frames);
  lengths.push_back(burst.size());
  for (const int frames : lengths) {
    nlohmann::json at;
    RunLength(burst, synth.truth, frames, &outcome, &at);
    line["lengths"].push_back(at);
  }
  std::printf("%s\n", line.dump().c_str());
  std::fflush(stdout);
  return outcome;
}

int RunGenerated(int bursts, unsigned seed, const std::string& camera, int frames, double scale,
                 const BurstLengthOptions& options) {
  const std::vector<SynthOptions> sweep = CalibrationSweepSettings(
      bursts, seed, SweepFieldOfView::kNormal, CameraEffects::Preset(camera), SweepMotion::kTremor);
  const double kFailed = 10.0;  // a failed depth counts as 1000 % AbsRel
  std::vector<double> chosen, ten, all;
  double frames_taken = 0.0;
  int too_still = 0;
  for (SynthOptions settings : sweep) {
    settings.frames = frames;
    settings.baseline *= scale;
    settings.rotation_deg *= scale;
    settings.reference = 0;
    const Outcome outcome = RunGeneratedBurst(settings, options);
    const auto abs_rel = [&](int k) {
      const auto found = outcome.abs_rel.find(k);
      return found == outcome.abs_rel.end() ? kFailed : found->second;
    };
    chosen.push_back(abs_rel(outcome.chosen));
    ten.push_back(abs_rel(std::min(10, frames)));
    all.push_back(abs_rel(frames));
    frames_taken += outcome.chosen;
    too_still += outcome.too_still;
  }
  const nlohmann::json summary = {
      {"bursts", sweep.size()},
      {"target_parallax_px", options.target_parallax_px},
      {"min_parallax_px", options.min_parallax_px},
      {"median_abs_rel_chosen", WindowMedian(chosen)},
      {"median_abs_rel_10_frames", WindowMedian(ten)},
      {"median_abs_rel_all_frames", WindowMedian(all)},
      {"worst_abs_rel_chosen", *std::max_element(chosen.begin(), chosen.end())},
      {"mean_frames_chosen", frames_taken / sweep.size()},
      {"too_still", too_still}};
  std::printf("%s\n", nlohmann::json({{"summary", summary}}).dump().c_str());
  return 0;
}

int RunBurst(const std::string& dir, const BurstLengthOptions& options) {
  Burst burst = ReadBurst(dir);
  // A recorded clip's reference is often its middle; a capture's is an end.
  if (burst.reference() != 0 && burst.reference() != burst.size() - 1) burst.manifest.reference = 0;
  const BurstLength length = ChooseBurstLength(burst, PipelineOptions(), options);
  std::printf("%s\n",
              nlohmann::json({{"burst", dir}, {"choice", ToJson(length, burst.size(), options)}})
                  .dump()
                  .c_str());
  return 0;
}

}  // namespace
}  // namespace dfsm

int main(int argc, char** argv) {
  int bursts = 16, frames = 30;
  unsigned seed = 3;
  double scale = 2.0;
  std::string camera = "phone", burst;
  dfsm::BurstLengthOptions options;
  try {
    for (int i = 1; i < argc; ++i) {
      const bool value = i + 1 < argc;
      if (!std::strcmp(argv[i], "--bursts") && value)
        bursts = dfsm::WholeNumber("--bursts", argv[++i], 1);
      else if (!std::strcmp(argv[i], "--seed") && value)
        seed = static_cast<unsigned>(dfsm::SeedNumber("--seed", argv[++i]));
      else if (!std::strcmp(argv[i], "--camera") && value)
        camera = argv[++i];
      else if (!std::strcmp(argv[i], "--frames") && value)
        frames = dfsm::WholeNumber("--frames", argv[++i], 3);
      else if (!std::strcmp(argv[i], "--motion-scale") && value)
        scale = dfsm::PositiveNumber("--motion-scale", argv[++i]);
      else if (!std::strcmp(argv[i], "--target") && value)
        options.target_parallax_px = dfsm::PositiveNumber("--target", argv[++i]);
      else if (!std::strcmp(argv[i], "--still") && value)
        options.min_parallax_px = dfsm::NonNegativeNumber("--still", argv[++i]);
      else if (!std::strcmp(argv[i], "--burst") && value)
        burst = argv[++i];
      else {
        std::fprintf(stderr,
                     "usage: burst_length [--bursts N] [--seed S] [--camera ideal|webcam|phone]\n"
                     "                    [--frames M] [--motion-scale X] [--target PX] "
                     "[--still PX]\n"
                     "       burst_length --burst DIR [--target PX] [--still PX]\n");
        return 2;
      }
    }
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "burst_length: %s\n", e.what());
    return 2;
  }
  try {
    options.Check();
    if (!burst.empty()) return dfsm::RunBurst(burst, options);
    return dfsm::RunGenerated(bursts, seed, camera, frames, scale, options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "burst_length: %s\n", e.what());
    return 1;
  }
}
