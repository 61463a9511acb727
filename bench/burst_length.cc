// How long a burst must be: the parallax a capture measures before any
// reconstruction (core/sparse/parallax_growth.h) against the depth the
// pipeline then makes of the first K frames. A JSON report, not a timing
// benchmark: it sets BurstLengthOptions' defaults (dfsmd's "frames": "auto").
//
//   burst_length [--bursts N] [--seed S] [--camera ideal|webcam|phone]
//                [--frames M] [--motion-scale X] [--lengths 5,7,10,15,20,30]
//   burst_length --tum DATASET [--start I] [--step J]
//   burst_length --burst DIR
//
// Generated: the calibration sweep's bursts (sizes, tremor, effects), each
// rendered with M frames (30) and its camera path's extent and rotation
// times X (2: a hand drifts further over a second than over a third); the
// pipeline runs on the first K frames for each K of --lengths (reference: the
// first frame, whose depth the ground truth holds). Printed per burst and K:
// the measured parallax, the pipeline's AbsRel, its parallax and its depth
// verdict; then, by bins of the measured parallax, the median AbsRel.
// TUM: each 10-frame window's measured parallax from its first frame on;
// --burst: a burst directory's.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "bench/tum_sequence.h"
#include "core/pipeline/evaluation.h"
#include "core/pipeline/frame_selection.h"
#include "core/pipeline/pipeline.h"
#include "core/sparse/parallax_growth.h"
#include "core/synth/burst_synthesizer.h"
#include "tests/support/calibration_sweep.h"

namespace dfsm {
namespace {

std::vector<int> ParseLengths(const std::string& text) {
  std::vector<int> lengths;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) lengths.push_back(std::atoi(item.c_str()));
  return lengths;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

ParallaxGrowthOptions probe;  // --pipeline-tracker sets its tracker

struct Sample {
  double measured_px = 0.0;
  double measured_p90_px = 0.0;
  double abs_rel = -1.0;  // -1: the pipeline failed
};

nlohmann::json RunGeneratedBurst(SynthOptions settings, const std::vector<int>& lengths,
                                 std::vector<Sample>* samples) {
  const SynthBurst synth = SynthesizeBurst(settings);
  const Burst burst = ToBurst(synth);
  const ParallaxGrowth growth = MeasureParallaxGrowth(burst.gray, probe);
  nlohmann::json line = {{"width", settings.width},
                         {"height", settings.height},
                         {"baseline_mm", settings.baseline * 1000.0},
                         {"rotation_deg", settings.rotation_deg},
                         {"seed", settings.seed},
                         {"tracks", growth.tracks},
                         {"tracked_frames", growth.tracked_frames},
                         {"growth_px", growth.parallax_px},
                         {"growth_p90_px", growth.parallax_p90_px}};
  const cv::Mat textured = TexturedMask(burst.gray[burst.reference()]);
  for (const int k : lengths) {
    if (k > burst.size()) continue;
    std::vector<int> first(k);
    for (int i = 0; i < k; ++i) first[i] = i;
    Sample sample;
    sample.measured_px = growth.parallax_px[k - 1];
    sample.measured_p90_px = growth.parallax_p90_px[k - 1];
    nlohmann::json at = {{"frames", k},
                         {"measured_px", sample.measured_px},
                         {"measured_p90_px", sample.measured_p90_px}};
    try {
      const PipelineOutput output = RunPipeline(SelectFrames(burst, first), PipelineOptions());
      if (output.dense) {
        sample.abs_rel = EvaluateDepth(output.dense->depth, synth.truth.depth, textured).abs_rel;
        at["abs_rel"] = sample.abs_rel;
        at["pipeline_parallax_px"] =
            output.result.extra.value("parallax", nlohmann::json()).value("median_px", 0.0);
        at["depth_verdict"] =
            output.result.extra.value("depth_verdict", nlohmann::json()).value("quality", "");
      }
    } catch (const std::exception& e) {
      at["error"] = e.what();
    }
    samples->push_back(sample);
    line["lengths"].push_back(at);
  }
  return line;
}

int RunGenerated(int bursts, unsigned seed, const std::string& camera, int frames, double scale,
                 const std::vector<int>& lengths) {
  std::vector<SynthOptions> sweep = CalibrationSweepSettings(
      bursts, seed, SweepFieldOfView::kNormal, CameraEffects::Preset(camera), SweepMotion::kTremor);
  std::vector<Sample> samples;
  for (SynthOptions settings : sweep) {
    settings.frames = frames;
    settings.baseline *= scale;
    settings.rotation_deg *= scale;
    settings.reference = 0;
    std::printf("%s\n", RunGeneratedBurst(settings, lengths, &samples).dump().c_str());
    std::fflush(stdout);
  }
  const std::vector<double> edges = {0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 1e9};
  nlohmann::json bins = nlohmann::json::array();
  for (size_t b = 0; b + 1 < edges.size(); ++b) {
    std::vector<double> abs_rel;
    int failed = 0;
    for (const Sample& sample : samples) {
      if (sample.measured_px < edges[b] || sample.measured_px >= edges[b + 1]) continue;
      if (sample.abs_rel < 0.0)
        ++failed;
      else
        abs_rel.push_back(sample.abs_rel);
    }
    bins.push_back({{"measured_px_from", edges[b]},
                    {"to", edges[b + 1]},
                    {"bursts", abs_rel.size()},
                    {"failed", failed},
                    {"median_abs_rel", Median(abs_rel)}});
  }
  std::printf("%s\n", nlohmann::json({{"summary", bins}}).dump().c_str());
  return 0;
}

int RunBurst(const std::string& dir) {
  const Burst burst = ReadBurst(dir);
  const ParallaxGrowth growth = MeasureParallaxGrowth(burst.gray, probe);
  std::printf("%s\n", nlohmann::json({{"burst", dir},
                                      {"tracks", growth.tracks},
                                      {"tracked_frames", growth.tracked_frames},
                                      {"focal_px", growth.focal_px},
                                      {"growth_px", growth.parallax_px},
                                      {"growth_p90_px", growth.parallax_p90_px}})
                          .dump()
                          .c_str());
  return 0;
}

int RunTum(const std::string& dataset, int start, int step) {
  const TumSequence sequence(dataset);
  if (sequence.empty()) {
    std::fprintf(stderr, "%s: no TUM sequence\n", dataset.c_str());
    return 1;
  }
  for (int first = start; first + 10 <= sequence.frames(); first += step) {
    const Burst burst = sequence.Window(first, 10);
    const ParallaxGrowth growth = MeasureParallaxGrowth(burst.gray, probe);
    std::printf("%s\n", nlohmann::json({{"window", first},
                                        {"tracks", growth.tracks},
                                        {"tracked_frames", growth.tracked_frames},
                                        {"growth_px", growth.parallax_px},
                                        {"growth_p90_px", growth.parallax_p90_px}})
                            .dump()
                            .c_str());
  }
  return 0;
}

}  // namespace
}  // namespace dfsm

int main(int argc, char** argv) {
  int bursts = 16, frames = 30, start = 1, step = 12;
  unsigned seed = 3;
  double scale = 2.0;
  std::string camera = "phone", tum, burst, lengths = "5,7,10,15,20,30";
  for (int i = 1; i < argc; ++i) {
    const bool value = i + 1 < argc;
    if (!std::strcmp(argv[i], "--bursts") && value)
      bursts = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--seed") && value)
      seed = static_cast<unsigned>(std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--camera") && value)
      camera = argv[++i];
    else if (!std::strcmp(argv[i], "--frames") && value)
      frames = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--motion-scale") && value)
      scale = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--lengths") && value)
      lengths = argv[++i];
    else if (!std::strcmp(argv[i], "--pipeline-tracker"))
      dfsm::probe.pipeline_tracker = true;
    else if (!std::strcmp(argv[i], "--burst") && value)
      burst = argv[++i];
    else if (!std::strcmp(argv[i], "--tum") && value)
      tum = argv[++i];
    else if (!std::strcmp(argv[i], "--start") && value)
      start = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--step") && value)
      step = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr,
                   "usage: burst_length [--bursts N] [--seed S] [--camera ideal|webcam|phone]\n"
                   "                    [--frames M] [--motion-scale X] [--lengths K,K,...]\n"
                   "       burst_length --tum DATASET [--start I] [--step J]\n"
                   "       burst_length --burst DIR\n");
      return 2;
    }
  }
  try {
    if (!burst.empty()) return dfsm::RunBurst(burst);
    if (!tum.empty()) return dfsm::RunTum(tum, start, step);
    return dfsm::RunGenerated(bursts, seed, camera, frames, scale, dfsm::ParseLengths(lengths));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "burst_length: %s\n", e.what());
    return 1;
  }
}
