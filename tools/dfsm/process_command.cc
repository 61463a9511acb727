// dfsm process INPUT --out DIR: the whole pipeline on a recorded burst, a
// folder of images or a glob of them.
#include <cstdio>
#include <filesystem>
#include <opencv2/core/utility.hpp>

#include "core/export/calibration_import.h"
#include "core/io/image_sequence.h"
#include "core/pipeline/pipeline.h"
#include "tools/dfsm/burst_input.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"

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
  std::string burst_dir, out_dir, init = InitModeName(InitMode::kRankOne);
  std::string rolling_shutter = kDefaultRollingShutter, calibration_file;
  std::string calibration_mode = KnownCalibrationModeName(KnownCalibrationMode::kPrior);
  PipelineOptions options;
  int frames = 0, start = 0;
  bool no_dense = false;
  int threads = 0;
  app.add_option("INPUT", burst_dir,
                 "a dfsm-burst/1 directory, a folder of PNG or JPEG images (in name order, "
                 "numbers compared as numbers) or a glob of them ('clip/*.jpg', quoted)")
      ->required();
  app.add_option("--out", out_dir, "result directory (dfsm-result/1); created when missing")
      ->required();
  app.add_option("--init", init,
                 "bundle-adjustment start (rank1 also probes the naive start beside its own and "
                 "keeps the one that fits every track better)")
      ->check(CLI::IsMember({InitModeName(InitMode::kRankOne), InitModeName(InitMode::kNaive)}))
      ->capture_default_str();
  app.add_option("--frames", frames,
                 "use N consecutive frames: of a burst centred on its reference, of images "
                 "from --start (0: all)")
      ->check(FrameCount());
  app.add_option("--start", start,
                 "images only: skip this many first (the first read is the "
                 "reference)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--grid", options.sparse.features.cell_px,
                 "feature cell size, pixels (0: 80 px at 1080p, scaled)")
      ->check(CLI::Range(0, GridedFeatureOptions::kMaxCellPx));
  app.add_option("--planes", options.dense.planes, "plane-sweep planes")
      ->check(CLI::Range(DenseOptions::kMinPlanes, DenseOptions::kMaxPlanes))
      ->capture_default_str();
  app.add_flag("--no-dense", no_dense, "stop after the sparse stage (no depth map)");
  app.add_option("--threads", threads, "worker threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-iterations", options.sparse.bundle_adjustment.max_iterations,
                 "bundle-adjustment iteration limit per run")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  CLI::Option* calibration = app.add_option(
      "--calibration", calibration_file,
      "a known calibration: dfsm's calibration.json/.yaml, an OpenCV FileStorage "
      "(camera_matrix, distortion_coefficients) or a ROS CameraInfo YAML; its principal point "
      "replaces the image centre");
  app.add_option("--calibration-mode", calibration_mode,
                 "hold it fixed, or use it as a prior (f 1 %, distortion 0.5 px)")
      ->check(CLI::IsMember({KnownCalibrationModeName(KnownCalibrationMode::kFixed),
                             KnownCalibrationModeName(KnownCalibrationMode::kPrior)}))
      ->needs(calibration)
      ->capture_default_str();
  app.add_option("--rolling-shutter", rolling_shutter,
                 "global | estimate | R: the sensor's readout: none, estimated by the "
                 "adjustment, or R of the frame interval (phones and most webcams read out row "
                 "by row; needs frames in capture order)")
      ->capture_default_str();
  if (const auto status = ParseCommandLine(app, args)) return *status;

  options.sparse.init = ParseInitMode(init);
  try {
    options.sparse.rolling_shutter = ParseRollingShutter(rolling_shutter);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--rolling-shutter: ") + e.what());
  }
  options.run_dense = !no_dense;
  if (threads > 0) cv::setNumThreads(threads);

  Burst burst;
  try {
    burst = ReadBurstInput(burst_dir, start, frames);
  } catch (const BurstError& e) {
    std::fprintf(stderr, "dfsm process: %s\n", e.what());
    return 1;
  }
  if (!calibration_file.empty()) {
    KnownCalibration known;
    known.mode = ParseKnownCalibrationMode(calibration_mode);
    const std::string& file = calibration_file;
    try {
      const ImportedCalibration imported = ReadCalibrationFile(file, burst.width(), burst.height());
      known.camera = imported.camera;
      known.source = "file:" + file + " (" + imported.format + ")";
      if (imported.fit_max_error_px > 0.0)
        std::fprintf(stderr,
                     "dfsm process: %s: fitted to ha2016-d2u, max error %.3f px, RMS %.3f px\n",
                     file.c_str(), imported.fit_max_error_px, imported.fit_rms_error_px);
      for (const std::string& note : imported.notes)
        std::fprintf(stderr, "dfsm process: %s: %s\n", file.c_str(), note.c_str());
    } catch (const CalibrationFileError& e) {
      std::fprintf(stderr, "dfsm process: %s\n", e.what());
      return 1;
    }
    options.sparse.known = known;
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
