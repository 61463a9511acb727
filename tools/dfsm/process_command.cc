// dfsm process INPUT --out DIR: the whole pipeline on a recorded burst, a
// folder of images or a glob of them.
#include <cstdio>
#include <filesystem>

#include "core/export/calibration_import.h"
#include "core/pipeline/pipeline.h"
#include "tools/dfsm/burst_input.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"
#include "tools/dfsm/process_options.h"

namespace dfsm::tools {

int RunProcessCommand(const Args& args) {
  CLI::App app(
      "Runs the pipeline on a dfsm-burst/1 directory, a folder of images or a glob of them, and "
      "writes a dfsm-result/1 "
      "directory.",
      "dfsm process");
  app.footer(
      "Exit status: 0 ok, 1 the burst could not be processed (result.json says why), "
      "2 usage.");
  std::string burst_dir, out_dir;
  int start = 0;
  ProcessSettings settings;
  app.add_option("INPUT", burst_dir,
                 "a dfsm-burst/1 directory, a video (MP4, MOV, MKV, AVI, WebM), a folder of PNG "
                 "or JPEG images (in name order, numbers compared as numbers) or a glob of them "
                 "('clip/*.jpg', quoted)")
      ->required();
  app.add_option("--out", out_dir, "result directory (dfsm-result/1); created when missing")
      ->required();
  app.add_option("--start", start,
                 "videos and images only: skip this many frames first (the first read is the "
                 "reference)")
      ->check(CLI::NonNegativeNumber);
  AddProcessOptions(app, &settings);
  if (const auto status = ParseCommandLine(app, args)) return *status;
  PipelineOptions options = ParsedPipelineOptions(settings);

  Burst burst;
  try {
    burst = ReadBurstInput(burst_dir, start, settings.frames);
    options = WithKnownCalibration(options, settings, burst, "dfsm process");
  } catch (const BurstError& e) {
    std::fprintf(stderr, "dfsm process: %s\n", e.what());
    return 1;
  } catch (const CalibrationFileError& e) {
    std::fprintf(stderr, "dfsm process: %s\n", e.what());
    return 1;
  }
  // Each lap as it ends: where a long burst is.
  PipelineOutput output = RunPipeline(burst, options, [](const std::string& lap, double fraction) {
    if (fraction >= 1.0) std::fprintf(stderr, "dfsm process: %s done\n", lap.c_str());
  });
  WritePipelineOutputs(out_dir, burst, &output);

  const Result& result = output.result;
  if (!result.ok) {
    std::fprintf(stderr, "dfsm process: failed: %s\n", result.error.c_str());
    return 1;
  }
  const BundleAdjustmentSummary& ba = result.bundle_adjustment;
  std::printf("burst       %s: %d frames %dx%d, reference %d\n", burst_dir.c_str(), burst.size(),
              burst.width(), burst.height(), burst.reference());
  std::printf("features    %d tracks used (%d corners detected)\n", result.features,
              result.features_detected);
  std::printf("calibration f = %.2f px, k1 = %.5f, k2 = %.5f (init f = %d)\n", result.calibration.f,
              result.calibration.k1, result.calibration.k2,
              std::max(burst.width(), burst.height()));
  const nlohmann::json& detail = result.calibration_detail;
  const nlohmann::json& uncertainty = detail.value("uncertainty", nlohmann::json::object());
  if (uncertainty.value("available", false))
    std::printf("            sigma_f %.2f %%, distortion sigma %.2f px\n",
                uncertainty.value("sigma_f_percent", 0.0),
                uncertainty.value("distortion_sigma_px", 0.0));
  std::printf("            %s (calibration: %s)\n", detail.value("quality", "").c_str(),
              detail.value("source", "").c_str());
  if (const auto bias = detail.find("noise_bias"); bias != detail.end())
    std::printf(
        "            noise bias f %+.2f px, k1 %+.4f, k2 %+.4f (%d replicas)%s\n",
        bias->value("f_px", 0.0), bias->value("k1", 0.0), bias->value("k2", 0.0),
        bias->value("replicas", 0),
        bias->value("usable", false) ? "" : ", not usable (too large, or most replicas failed)");
  const nlohmann::json& shutter = detail.value("rolling_shutter", nlohmann::json::object());
  if (shutter.value("mode", "global") != "global")
    std::printf("shutter     rolling, readout %.3f of the frame interval (%s)\n",
                shutter.value("readout", 0.0), shutter.value("mode", "").c_str());
  std::printf("bundle adj. init %s, %zu runs, iterations", ba.init.c_str(), ba.runs.size());
  for (const BundleAdjustmentRun& run : ba.runs) std::printf(" %d", run.iterations);
  std::printf(", %s, cost %.4g -> %.4g, rms %.3f px\n",
              ba.converged ? "converged" : "NOT converged", ba.initial_cost, ba.final_cost,
              ba.rms_reprojection_px);
  for (const std::string& warning : result.warnings)
    std::printf("warning     %s\n", warning.c_str());
  if (result.depth)
    std::printf("depth       %d planes, %.1f %% valid\n", result.depth->planes,
                100.0 * result.depth->valid_fraction);
  std::printf("timings ms ");
  for (const auto& [stage, ms] : result.timings_ms) std::printf(" %s %.1f", stage.c_str(), ms);
  std::printf("\nresult      %s/result.json\n", out_dir.c_str());
  return 0;
}

}  // namespace dfsm::tools
