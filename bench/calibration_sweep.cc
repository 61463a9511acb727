// The calibration sweep (tests/support/calibration_sweep.h): one JSON line per
// burst, then the summary line. Measures whether sigma_f, the distortion sigma
// and the verdict are honest over the settings a user meets.
//   calibration_sweep [--bursts N] [--seed S] [--no-weak-prior]
//                     [--field-of-view normal|wide] (f 0.8-1.5 or 0.55-0.8 x
//                     the longer side) [--only I] (burst I of the sweep alone)
//                     [--motion tremor|rotation] (0.25-2 deg and 3-10 mm, or
//                     rotation-dominant 1-6 deg and 1-10 mm)
//                     [--focal-starts F1,F2,...] (SparseOptions::focal_starts)
//                     [--without LAYER,...] (sparse layers off: core/sparse/sparse_layers.h)
//                     [--line-path] (rows and blur on the line between frame poses,
//                     not the hand's own path: SynthOptions::hand_path)
#include "tests/support/calibration_sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "bench/report_options.h"
#include "core/sparse/sparse_layers.h"

int main(int argc, char** argv) {
  using namespace dfsm;
  int bursts = 64;
  uint64_t seed = 1;
  SparseOptions options;
  double cell_scale = 1.0;  // feature cell against the default (0.5: four times the cells)
  int only = -1;            // every burst
  std::string field_of_view = "normal";
  std::string motion = "tremor";
  std::string camera = "ideal";  // camera effects preset of the generated bursts
  bool line_path = false;        // rows on the line between frame poses
  try {
    for (int i = 1; i < argc; ++i) {
      if (!std::strcmp(argv[i], "--bursts") && i + 1 < argc)
        bursts = WholeNumber("--bursts", argv[++i], 1);
      else if (!std::strcmp(argv[i], "--seed") && i + 1 < argc)
        seed = SeedNumber("--seed", argv[++i]);
      else if (!std::strcmp(argv[i], "--no-weak-prior"))
        options.bundle_adjustment.log_f_prior_sigma = 0.0;
      else if (!std::strcmp(argv[i], "--corner-prior") && i + 1 < argc)
        options.bundle_adjustment.corner_shift_prior_sigma =
            PositiveNumber("--corner-prior", argv[++i]);
      else if (!std::strcmp(argv[i], "--lens-prior") && i + 1 < argc)
        options.bundle_adjustment.lens_k_prior_sigma = NonNegativeNumber("--lens-prior", argv[++i]);
      else if (!std::strcmp(argv[i], "--cell-scale") && i + 1 < argc)
        cell_scale = PositiveNumber("--cell-scale", argv[++i]);
      else if (!std::strcmp(argv[i], "--camera") && i + 1 < argc)
        camera = argv[++i];
      else if (!std::strcmp(argv[i], "--field-of-view") && i + 1 < argc)
        field_of_view = argv[++i];
      else if (!std::strcmp(argv[i], "--motion") && i + 1 < argc)
        motion = argv[++i];
      else if (!std::strcmp(argv[i], "--only") && i + 1 < argc)
        only = WholeNumber("--only", argv[++i], 0);
      else if (!std::strcmp(argv[i], "--focal-starts") && i + 1 < argc) {
        // Comma-separated fractions of max(width, height); "1" is the single
        // start of the code before the focal starts.
        options.focal_starts.clear();
        const char* list = argv[++i];
        for (std::string rest = list;;) {
          const size_t comma = rest.find(',');
          options.focal_starts.push_back(PositiveNumber("--focal-starts", rest.substr(0, comma)));
          if (comma == std::string::npos) break;
          rest = rest.substr(comma + 1);
        }
      } else if (!std::strcmp(argv[i], "--line-path")) {
        line_path = true;
      } else if (!std::strcmp(argv[i], "--without") && i + 1 < argc) {
        options = WithoutLayers(options, argv[++i]);
      } else {
        std::fprintf(stderr,
                     "usage: calibration_sweep [--bursts N] [--seed S] [--no-weak-prior]\n"
                     "                         [--lens-prior SIGMA] [--corner-prior SIGMA] "
                     "[--cell-scale S]\n"
                     "                         [--camera ideal|webcam|phone]\n"
                     "                         [--field-of-view normal|wide] [--only I]\n"
                     "                         [--motion tremor|rotation]\n"
                     "                         [--focal-starts F1,F2,...] [--without LAYER,...]\n"
                     "                         [--line-path]\n");
        return 2;
      }
    }
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "calibration_sweep: %s\n", e.what());
    return 2;
  }
  std::vector<SweepOutcome> outcomes;
  SweepFieldOfView lens;
  SweepMotion hand;
  try {
    lens = ParseSweepFieldOfView(field_of_view);
    hand = ParseSweepMotion(motion);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "calibration_sweep: %s\n", e.what());
    return 2;
  }
  std::vector<SynthOptions> sweep =
      CalibrationSweepSettings(bursts, seed, lens, CameraEffects::Preset(camera), hand);
  if (only >= static_cast<int>(sweep.size())) {
    std::fprintf(stderr, "--only %d: the sweep has %zu bursts (0-%zu)\n", only, sweep.size(),
                 sweep.size() - 1);
    return 2;
  }
  if (only >= 0) sweep = {sweep[only]};
  if (line_path)
    for (SynthOptions& settings : sweep) settings.hand_path = false;
  for (SynthOptions settings : sweep) {
    SparseOptions burst_options = options;
    if (cell_scale != 1.0)  // the default cell of this size, scaled
      burst_options.features.cell_px = std::max(
          8, static_cast<int>(
                 std::lround(cell_scale * GridCellSize({}, settings.width, settings.height))));
    outcomes.push_back(RunSweepBurst(settings, burst_options));
    std::printf("%s\n", ToJson(outcomes.back()).dump().c_str());
    std::fflush(stdout);
  }
  std::printf("%s\n", nlohmann::json{{"summary", ToJson(Summarize(outcomes))}}.dump().c_str());

  // The docs table: one row per resolution, then all.
  std::printf(
      "\n| size | bursts | median / max f error %% | less the noise bias %% | f within 2 sigma "
      "| distortion within 2 sigma | reliable / uncertain / degenerate | max f error of "
      "reliable %% |\n"
      "|---|---|---|---|---|---|---|---|\n");
  // Median and largest of |errors| (0 where empty).
  const auto median_max = [](std::vector<double> errors) {
    for (double& error : errors) error = std::abs(error);
    std::sort(errors.begin(), errors.end());
    return errors.empty() ? std::pair(0.0, 0.0)
                          : std::pair(errors[errors.size() / 2], errors.back());
  };
  const auto row = [&](const char* name, const std::vector<SweepOutcome>& group) {
    std::vector<double> errors, debiased;
    for (const SweepOutcome& o : group)
      if (o.reconstructed) {
        errors.push_back(o.f_error_percent);
        debiased.push_back(o.debiased_f_error_percent);
      }
    const auto [median, max] = median_max(errors);
    const auto [debiased_median, debiased_max] = median_max(debiased);
    const SweepSummary s = Summarize(group);
    std::printf(
        "| %s | %d | %.2f / %.2f | %.2f / %.2f | %.0f %% | %.0f %% | %d / %d / %d | %.2f |\n", name,
        s.bursts, median, max, debiased_median, debiased_max, 100.0 * s.f_within_2_sigma,
        100.0 * s.distortion_within_2_sigma, s.reliable, s.uncertain, s.degenerate,
        s.reliable_max_f_error_percent);
  };
  for (const SweepSize& size : SweepSizes()) {
    std::vector<SweepOutcome> group;
    for (const SweepOutcome& o : outcomes)
      if (o.settings.width == size.width) group.push_back(o);
    if (!group.empty()) row(std::to_string(size.width).c_str(), group);
  }
  row("all", outcomes);
  return 0;
}
