// dfsm process BURST --out DIR: the whole pipeline on a recorded burst.
#include <cstdio>
#include <opencv2/core/utility.hpp>

#include "core/export/calibration_import.h"
#include "core/pipeline/pipeline.h"
#include "tools/dfsm/arg_parser.h"
#include "tools/dfsm/command.h"

namespace dfsm::tools {
namespace {

constexpr const char* kHelp =
    "usage: dfsm process BURST --out DIR [options]\n"
    "\n"
    "  --out DIR            result directory (dfsm-result/1); created when missing\n"
    "  --init rank1|naive   bundle-adjustment start (default rank1)\n"
    "  --frames N           use N consecutive frames centred on the reference (default: all)\n"
    "  --grid PX            feature cell size (default: 80 px at 1080p, scaled)\n"
    "  --planes N           plane-sweep planes (default 128)\n"
    "  --no-dense           stop after the sparse stage (no depth map)\n"
    "  --threads N          worker threads (default: all cores)\n"
    "  --max-iterations N   bundle-adjustment iteration limit per run (default 100)\n"
    "  --calibration FILE   a known calibration: dfsm's calibration.json/.yaml, an OpenCV\n"
    "                       FileStorage (camera_matrix, distortion_coefficients) or a ROS\n"
    "                       CameraInfo YAML; its principal point replaces the image centre\n"
    "  --calibration-mode fixed|prior\n"
    "                       hold it fixed, or use it as a prior (f 1 %, distortion 0.5 px;\n"
    "                       default prior)\n"
    "  --rolling-shutter global|estimate|R\n"
    "                       the sensor's readout: none, estimated by the adjustment, or\n"
    "                       R of the frame interval (default estimate: phones and most\n"
    "                       webcams read out row by row; needs frames in capture order)\n"

    "\n"
    "Exit status: 0 ok, 1 the burst could not be processed (result.json says why), 2 usage.\n";

}  // namespace

int RunProcessCommand(const Args& args) {
  ArgParser parser({"out", "init", "frames", "grid", "planes", "threads", "max-iterations",
                    "calibration", "calibration-mode", "rolling-shutter"},
                   {"no-dense", "help"});
  parser.Parse(args);
  if (parser.Has("help")) {
    std::fputs(kHelp, stdout);
    return 0;
  }
  if (parser.positionals().size() != 1) throw UsageError("expected exactly one BURST directory");
  if (!parser.Has("out")) throw UsageError("--out DIR is required");

  PipelineOptions options;
  try {
    options.sparse.init = ParseInitMode(parser.String("init", "rank1"));
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--init: ") + e.what());
  }
  try {
    options.sparse.rolling_shutter =
        ParseRollingShutter(parser.String("rolling-shutter", kDefaultRollingShutter));
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--rolling-shutter: ") + e.what());
  }
  options.sparse.features.cell_px = parser.Int("grid", 0);
  if (options.sparse.features.cell_px < 0 || options.sparse.features.cell_px > 4096)
    throw UsageError("--grid must be between 1 and 4096 pixels");
  options.dense.planes = parser.Int("planes", 128);
  if (options.dense.planes < 2 || options.dense.planes > 1024)
    throw UsageError("--planes must be between 2 and 1024");
  options.sparse.bundle_adjustment.max_iterations = parser.Int("max-iterations", 100);
  if (options.sparse.bundle_adjustment.max_iterations < 1)
    throw UsageError("--max-iterations must be positive");
  options.run_dense = !parser.Has("no-dense");
  const int threads = parser.Int("threads", 0);
  if (threads < 0) throw UsageError("--threads must not be negative");
  if (threads > 0) cv::setNumThreads(threads);
  ReadBurstOptions read_options;
  read_options.max_frames = parser.Int("frames", 0);
  if (read_options.max_frames < 0 || read_options.max_frames == 1 || read_options.max_frames == 2)
    throw UsageError("--frames must be at least 3");

  const std::string burst_dir = parser.positionals()[0];
  const std::string out_dir = parser.String("out", "");
  Burst burst;
  try {
    burst = ReadBurst(burst_dir, read_options);
  } catch (const BurstError& e) {
    std::fprintf(stderr, "dfsm process: %s\n", e.what());
    return 1;
  }
  if (parser.Has("calibration")) {
    KnownCalibration known;
    try {
      known.mode = ParseKnownCalibrationMode(parser.String("calibration-mode", "prior"));
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--calibration-mode: ") + e.what());
    }
    const std::string file = parser.String("calibration", "");
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
  } else if (parser.Has("calibration-mode")) {
    throw UsageError("--calibration-mode needs --calibration FILE");
  }
  PipelineOutput output = RunPipeline(burst, options, [](const std::string& stage) {
    std::fprintf(stderr, "dfsm process: %s...\n", stage.c_str());
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
