// The depth sweep: the calibration sweep's bursts (tests/support/calibration_sweep.h:
// 320x240-1080p, tremor 0.25-2 deg, baseline 3-10 mm, k1 of either sign, JPEG
// on and off), rendered with a camera preset's effects and run through the
// whole pipeline, dense stage included. Each depth map is scored against the
// burst's ground truth beside what the result says of itself: the depth check
// (confirmed or its warnings), the relief's sigma and the calibration's verdict.
// It measures what a user meets away from one favourable setting, and whether
// a depth called confirmed is one to trust (docs/experiments/228-depth-sweep.md).
// One JSON line per burst, then the summary line and the docs table.
//   depth_sweep [--bursts N] [--seed S] [--camera ideal|webcam|phone]
//               [--field-of-view normal|wide] [--motion tremor|rotation]
//               (tremor 0.25-2 deg and 3-10 mm, or rotation-dominant 1-6 deg
//               and 1-10 mm) [--only I [--keep DIR]] (DIR/burst,
//               DIR/result: the burst and its result, for dfsm evaluate)
//   depth_sweep --defaults N [--camera ...]: instead of the sweep, the camera
//               preset at the generator's default strengths, seeds 1-N at every
//               size (DefaultStrengthSettings): the bursts the targets
//               name; a table of means and medians per size follows the docs table.
//   --known prior|fixed|fused: each burst given its own camera as a known
//               calibration (the model's f, k1, k2; not its k3, p1, p2); fused:
//               as dfsmd gives its fused calibration (a prior at the fusion's
//               least widths, no fit check, the burst also calibrated alone:
//               daemon/service/calibration_keeper.cc).
//   --without LAYER,...: sparse layers switched off by name
//               (core/sparse/sparse_layers.h).
//   --line-path: rows and blur rendered on the line between frame poses (the
//               pipeline's own rolling-shutter model), not the hand's own path
//               between frames (SynthOptions::hand_path, the default;
//               --hand-path is accepted and changes nothing).
//   --oscillation DEG: a hand's physiological tremor on every burst's
//               orientation (SynthOptions::oscillation_deg); on the hand's
//               path the turn bends within a frame's readout, as on real
//               footage.
//   --exif: each burst carries its true focal length as EXIF's 35 mm
//               equivalent, in whole mm as cameras write it (a prior on f).
//   --rolling-shutter global|estimate|R: the pipeline's rolling-shutter mode
//               (estimate, the default; R: a readout held, as a device's
//               datasheet gives it).
//   --pinned-depth: each burst's JSON line also carries "pinned", the
//               sparse stage's tracks pinned to the true depth
//               (bench/pinned_depth.h; docs/experiments/032-tracks-pinned-to-the-true-depth.md).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/pinned_depth.h"
#include "bench/report_options.h"
#include "core/io/exif_focal.h"
#include "core/pipeline/evaluation.h"
#include "core/pipeline/pipeline.h"
#include "core/sparse/calibration_fusion.h"
#include "core/sparse/sparse_layers.h"
#include "core/synth/burst_synthesizer.h"
#include "tests/support/calibration_sweep.h"

namespace dfsm {
namespace {

// A depth this far off (AbsRel, after the one global scale) is one a user
// should not have been told to trust.
constexpr double kUntrustedAbsRel = 0.05;

struct DepthSweepOutcome {
  SynthOptions settings;
  bool ok = false;
  std::string error;
  SparseEvaluation sparse;
  DepthEvaluation measured, filled;
  bool confirmed = false;
  nlohmann::json depth_check;  // result.json's, whole
  std::string depth_quality;   // result.json's depth_verdict.quality
  // result.json's sparse_detail (tracks tracked, inliers, ...) and which
  // start won (bundle_adjustment.from_self_calibration).
  nlohmann::json sparse_detail;
  std::string quality;
  std::vector<std::string> warnings;
  double total_ms = 0.0;
  // bench/pinned_depth.h's oracle, where --pinned-depth asked for it.
  nlohmann::json pinned;
};

// keep: where not empty, the burst is written to keep/burst and its result
// to keep/result, for `dfsm evaluate` and a look at the maps.
// known: where set, the burst's own camera (f, k1, k2 of its ground truth;
// the rendered k3, p1, p2 are not in the model) is given as a known
// calibration in that mode, as a user gives a calibration file; `fused`: as
// dfsmd gives a fused calibration.
DepthSweepOutcome RunDepthSweepBurst(const SynthOptions& settings, const std::string& keep,
                                     PipelineOptions pipeline,
                                     std::optional<KnownCalibrationMode> known, bool fused,
                                     bool exif, bool pinned) {
  DepthSweepOutcome outcome;
  outcome.settings = settings;
  const SynthBurst synth = SynthesizeBurst(settings);
  Burst burst = ToBurst(synth);
  if (exif)
    burst.exif_focal_35mm =
        std::round(Focal35mmFromPixels(synth.truth.camera.f, burst.width(), burst.height()));
  if (!keep.empty()) WriteSynthBurst(std::filesystem::path(keep) / "burst", synth);
  if (known && fused) {
    // As sure of it as a fusion can be: the widths at their floors.
    pipeline.sparse.known = FusedCalibrationPrior(synth.truth.camera, 0.0, 0.0, "truth");
  } else if (known) {
    KnownCalibration calibration;
    calibration.camera = synth.truth.camera;
    calibration.mode = *known;
    calibration.source = "truth";
    pipeline.sparse.known = calibration;
  }
  const auto start = std::chrono::steady_clock::now();
  PipelineOutput output = RunPipeline(burst, pipeline);
  outcome.total_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!keep.empty()) WritePipelineOutputs(std::filesystem::path(keep) / "result", burst, &output);
  outcome.ok = output.result.ok && output.sparse && output.dense;
  if (!outcome.ok) {
    outcome.error = output.result.error;
    return outcome;
  }
  outcome.sparse = EvaluateSparse(output.sparse->state.camera, output.result.poses, synth.truth);
  const cv::Mat textured = TexturedMask(burst.gray[burst.reference()]);
  outcome.measured = EvaluateDepth(output.dense->depth, synth.truth.depth, textured);
  outcome.filled = EvaluateDepth(output.dense->depth_filled, synth.truth.depth, textured);
  // What the result says of itself, as result.json says it.
  const nlohmann::json& check = output.result.extra.at("depth_check");
  outcome.confirmed = check.at("confirmed").get<bool>();
  outcome.depth_check = check;
  outcome.depth_quality = output.result.extra.at("depth_verdict").at("quality").get<std::string>();
  outcome.sparse_detail = output.result.extra.at("sparse_detail");
  outcome.sparse_detail["parallax"] = output.result.extra.at("parallax");
  outcome.sparse_detail["from_self_calibration"] =
      output.result.bundle_adjustment.from_self_calibration;
  outcome.quality = output.result.calibration_detail.value("quality", "");
  outcome.warnings = output.result.warnings;
  if (pinned) {
    const std::optional<PinnedDepth> oracle = PinDepthToTruth(
        burst, synth.truth.depth, textured, *output.sparse, pipeline.sparse, pipeline.dense);
    if (oracle) outcome.pinned = ToJson(*oracle);
  }
  return outcome;
}

nlohmann::json ToJson(const DepthSweepOutcome& o) {
  nlohmann::json j = SweepSettingsJson(o.settings);
  j["ok"] = o.ok;
  j["total_ms"] = o.total_ms;
  if (!o.ok) {
    j["error"] = o.error;
    return j;
  }
  j["sparse"] = ToJson(o.sparse);
  j["depth"] = ToJson(o.measured);
  j["filled"] = ToJson(o.filled);
  j["confirmed"] = o.confirmed;
  j["relief_sigma"] = o.depth_check.at("relief_sigma");
  j["depth_check"] = o.depth_check;
  j["depth_quality"] = o.depth_quality;
  j["sparse_detail"] = o.sparse_detail;
  j["quality"] = o.quality;
  j["warnings"] = o.warnings;
  if (!o.pinned.is_null()) j["pinned"] = o.pinned;
  return j;
}

// The upper of the two middle values for an even count, as every table of
// this sweep in docs/experiments/228-depth-sweep.md was made.
double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

// One docs-table row over a group of bursts.
void PrintRow(const std::string& name, const std::vector<DepthSweepOutcome>& group) {
  std::vector<double> measured, filled, coverage, after_offset;
  int ok = 0, confirmed = 0, untrusted_confirmed = 0, flagged_bad = 0, bad = 0;
  double worst_confirmed = 0.0;
  for (const DepthSweepOutcome& o : group) {
    if (!o.ok) continue;
    ++ok;
    measured.push_back(100.0 * o.measured.abs_rel);
    filled.push_back(100.0 * o.filled.abs_rel);
    coverage.push_back(100.0 * o.measured.coverage);
    after_offset.push_back(100.0 * o.measured.abs_rel_after_offset);
    const bool untrusted = o.measured.abs_rel > kUntrustedAbsRel;
    bad += untrusted;
    flagged_bad += untrusted && !o.confirmed;
    if (o.confirmed) {
      ++confirmed;
      untrusted_confirmed += untrusted;
      worst_confirmed = std::max(worst_confirmed, 100.0 * o.measured.abs_rel);
    }
  }
  std::printf("| %s | %zu | %d | %.2f / %.2f | %.2f | %.1f | %d | %.2f | %d | %d of %d | %.2f |\n",
              name.c_str(), group.size(), ok, Median(measured),
              measured.empty() ? 0.0 : *std::max_element(measured.begin(), measured.end()),
              Median(filled), Median(coverage), confirmed, worst_confirmed, untrusted_confirmed,
              flagged_bad, bad, Median(after_offset));
}

// The outcomes of the bursts of one size.
std::vector<DepthSweepOutcome> OfSize(const std::vector<DepthSweepOutcome>& outcomes,
                                      const SweepSize& size) {
  std::vector<DepthSweepOutcome> group;
  for (const DepthSweepOutcome& o : outcomes)
    if (o.settings.width == size.width && o.settings.height == size.height) group.push_back(o);
  return group;
}

// The figures per size: AbsRel of depth.tiff and of depth_filled.tiff
// (mean and median), and the filled map's share within 5 % and coverage.
void PrintTargetRows(const std::vector<DepthSweepOutcome>& outcomes) {
  std::printf(
      "\n| size | bursts | processed | AbsRel mean / upper median %% | filled AbsRel mean / upper "
      "median %% | "
      "filled within 5 %% upper median (min) %% | filled coverage upper median %% |\n"
      "|---|---|---|---|---|---|---|\n");
  for (const SweepSize& size : SweepSizes()) {
    const std::vector<DepthSweepOutcome> group = OfSize(outcomes, size);
    std::vector<double> measured, filled, within, coverage;
    for (const DepthSweepOutcome& o : group) {
      if (!o.ok) continue;
      measured.push_back(100.0 * o.measured.abs_rel);
      filled.push_back(100.0 * o.filled.abs_rel);
      within.push_back(100.0 * o.filled.within_5_percent);
      coverage.push_back(100.0 * o.filled.coverage);
    }
    if (group.empty()) continue;
    const auto mean = [](const std::vector<double>& v) {
      double sum = 0.0;
      for (const double x : v) sum += x;
      return v.empty() ? 0.0 : sum / v.size();
    };
    std::printf("| %dx%d | %zu | %zu | %.2f / %.2f | %.2f / %.2f | %.1f (%.1f) | %.1f |\n",
                size.width, size.height, group.size(), measured.size(), mean(measured),
                Median(measured), mean(filled), Median(filled), Median(within),
                within.empty() ? 0.0 : *std::min_element(within.begin(), within.end()),
                Median(coverage));
  }
}

}  // namespace
}  // namespace dfsm

int main(int argc, char** argv) {
  using namespace dfsm;
  int bursts = 64, only = -1, defaults = 0;
  bool defaults_given = false, sweep_option_given = false;
  uint64_t seed = 1;
  std::string camera = "phone", field_of_view = "normal", motion = "tremor", keep;
  PipelineOptions pipeline;
  std::optional<KnownCalibrationMode> known;
  bool fused = false, exif = false, pinned = false;
  double oscillation_deg = 0.0;
  bool line_path = false;
  try {
    for (int i = 1; i < argc; ++i) {
      if (!std::strcmp(argv[i], "--bursts") && i + 1 < argc) {
        sweep_option_given = true;
        bursts = WholeNumber("--bursts", argv[++i], 1);
      } else if (!std::strcmp(argv[i], "--seed") && i + 1 < argc) {
        sweep_option_given = true;
        seed = SeedNumber("--seed", argv[++i]);
      } else if (!std::strcmp(argv[i], "--camera") && i + 1 < argc) {
        camera = argv[++i];
      } else if (!std::strcmp(argv[i], "--field-of-view") && i + 1 < argc) {
        sweep_option_given = true;
        field_of_view = argv[++i];
      } else if (!std::strcmp(argv[i], "--motion") && i + 1 < argc) {
        sweep_option_given = true;
        motion = argv[++i];
      } else if (!std::strcmp(argv[i], "--defaults") && i + 1 < argc) {
        defaults = WholeNumber("--defaults", argv[++i], 1);
        defaults_given = true;
      } else if (!std::strcmp(argv[i], "--only") && i + 1 < argc) {
        only = WholeNumber("--only", argv[++i], 0);
      } else if (!std::strcmp(argv[i], "--keep") && i + 1 < argc) {
        keep = argv[++i];
      } else if (!std::strcmp(argv[i], "--known") && i + 1 < argc) {
        ++i;
        fused = !std::strcmp(argv[i], "fused");
        known = fused ? KnownCalibrationMode::kPrior : ParseKnownCalibrationMode(argv[i]);
      } else if (!std::strcmp(argv[i], "--exif")) {
        exif = true;
      } else if (!std::strcmp(argv[i], "--rolling-shutter") && i + 1 < argc) {
        pipeline.sparse.rolling_shutter = ParseRollingShutter(argv[++i]);
      } else if (!std::strcmp(argv[i], "--pinned-depth")) {
        pinned = true;
      } else if (!std::strcmp(argv[i], "--oscillation") && i + 1 < argc) {
        oscillation_deg = NonNegativeNumber("--oscillation", argv[++i]);
      } else if (!std::strcmp(argv[i], "--hand-path")) {
        // the default; accepted so that older command lines still run
      } else if (!std::strcmp(argv[i], "--line-path")) {
        line_path = true;
      } else if (!std::strcmp(argv[i], "--reweight-rounds") && i + 1 < argc) {
        // 0: every track weighs the same
        pipeline.sparse.reweight_rounds = WholeNumber("--reweight-rounds", argv[++i], 0);
      } else if (!std::strcmp(argv[i], "--without") && i + 1 < argc) {
        pipeline.sparse = WithoutLayers(pipeline.sparse, argv[++i]);
      } else {
        std::fprintf(
            stderr,
            "usage: depth_sweep [--bursts N] [--seed S] [--camera ideal|webcam|phone]\n"
            "                   [--field-of-view normal|wide] [--motion tremor|rotation]\n"
            "                   [--only I [--keep DIR]]\n"
            "                   [--reweight-rounds N] [--known prior|fixed|fused] [--exif]\n"
            "                   [--without LAYER,...] [--line-path] [--oscillation DEG]\n"
            "                   [--rolling-shutter global|estimate|R] [--pinned-depth]\n"
            "       depth_sweep --defaults N [--camera ...] [--only I [--keep DIR]]\n"
            "                   [--known prior|fixed|fused] [--exif]\n");
        return 2;
      }
    }
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "depth_sweep: %s\n", e.what());
    return 2;
  }
  if (defaults_given && sweep_option_given) {
    std::fprintf(stderr,
                 "--defaults N: N seeds per size, N >= 1, without --bursts, --seed or "
                 "--field-of-view or --motion (those choose the sweep's bursts)\n");
    return 2;
  }
  std::vector<SynthOptions> sweep;
  try {
    if (defaults_given)
      sweep = DefaultStrengthSettings(defaults, camera);
    else
      sweep = CalibrationSweepSettings(bursts, seed, ParseSweepFieldOfView(field_of_view),
                                       CameraEffects::Preset(camera), ParseSweepMotion(motion));
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  if (only >= static_cast<int>(sweep.size())) {
    std::fprintf(stderr, "--only %d: the sweep has %zu bursts (0-%zu)\n", only, sweep.size(),
                 sweep.size() - 1);
    return 2;
  }
  if (!keep.empty() && only < 0) {
    std::fprintf(stderr, "--keep DIR writes one burst: it needs --only I\n");
    return 2;
  }
  if (only >= 0) sweep = {sweep[only]};
  for (SynthOptions& settings : sweep) {
    settings.oscillation_deg = oscillation_deg;
    if (line_path) settings.hand_path = false;
  }
  std::vector<DepthSweepOutcome> outcomes;
  for (const SynthOptions& settings : sweep) {
    outcomes.push_back(RunDepthSweepBurst(settings, keep, pipeline, known, fused, exif, pinned));
    std::printf("%s\n", ToJson(outcomes.back()).dump().c_str());
    std::fflush(stdout);
  }

  std::printf(
      "\n| group | bursts | processed | median / max AbsRel %% | median filled AbsRel %% | median "
      "coverage %% | confirmed | max AbsRel of confirmed %% | confirmed over 5 %% | over 5 %% "
      "not confirmed | median AbsRel after the inverse-depth offset %% |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const SweepSize& size : SweepSizes()) {
    const std::vector<DepthSweepOutcome> group = OfSize(outcomes, size);
    if (!group.empty())
      PrintRow(std::to_string(size.width) + "x" + std::to_string(size.height), group);
  }
  for (const double tremor : SweepTremors(ParseSweepMotion(motion))) {
    std::vector<DepthSweepOutcome> group;
    for (const DepthSweepOutcome& o : outcomes)
      if (o.settings.rotation_deg == tremor) group.push_back(o);
    if (!group.empty()) {
      char name[32];
      std::snprintf(name, sizeof(name), "%.2g deg", tremor);
      PrintRow(name, group);
    }
  }
  PrintRow("all", outcomes);
  if (defaults_given) PrintTargetRows(outcomes);
  return 0;
}
