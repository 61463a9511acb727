#include "tools/dfsm/process_options.h"

#include <cstdio>
#include <opencv2/core/utility.hpp>

#include "core/export/calibration_import.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"

namespace dfsm::tools {

ProcessSettings::ProcessSettings()
    : init(InitModeName(InitMode::kRankOne)),
      rolling_shutter(kDefaultRollingShutter),
      calibration_mode(KnownCalibrationModeName(KnownCalibrationMode::kPrior)) {}

void AddProcessOptions(CLI::App& app, ProcessSettings* settings) {
  PipelineOptions& options = settings->options;
  app.add_option("--init", settings->init,
                 "bundle-adjustment start (rank1 also probes the naive start beside its own and "
                 "keeps the one that fits every track better)")
      ->check(CLI::IsMember({InitModeName(InitMode::kRankOne), InitModeName(InitMode::kNaive)}))
      ->capture_default_str();
  app.add_option("--frames", settings->frames,
                 "use N consecutive frames: of a burst centred on its reference, of a video or "
                 "images from the first read (0: all)")
      ->check(FrameCount());
  app.add_option("--grid", options.sparse.features.cell_px,
                 "feature cell size, pixels (0: 80 px at 1080p, scaled)")
      ->check(CLI::Range(0, GridedFeatureOptions::kMaxCellPx));
  app.add_option("--planes", options.dense.planes, "plane-sweep planes")
      ->check(CLI::Range(DenseOptions::kMinPlanes, DenseOptions::kMaxPlanes))
      ->capture_default_str();
  app.add_flag("--no-dense", settings->no_dense, "stop after the sparse stage (no depth map)");
  app.add_option("--threads", settings->threads, "worker threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-iterations", options.sparse.bundle_adjustment.max_iterations,
                 "bundle-adjustment iteration limit per run")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  CLI::Option* calibration = app.add_option(
      "--calibration", settings->calibration_file,
      "a known calibration: dfsm's calibration.json/.yaml, an OpenCV FileStorage "
      "(camera_matrix, distortion_coefficients) or a ROS CameraInfo YAML; its principal point "
      "replaces the image centre, and an OpenCV lens that ha2016-d2u misses by 0.1 px or more "
      "has the frames resampled from it");
  app.add_option("--calibration-mode", settings->calibration_mode,
                 "hold it fixed, or use it as a prior (f 1 %, distortion 0.5 px)")
      ->check(CLI::IsMember({KnownCalibrationModeName(KnownCalibrationMode::kFixed),
                             KnownCalibrationModeName(KnownCalibrationMode::kPrior)}))
      ->needs(calibration)
      ->capture_default_str();
  app.add_option("--rolling-shutter", settings->rolling_shutter,
                 "global | estimate | R: the sensor's readout: none, estimated by the "
                 "adjustment, or R of the frame interval (phones and most webcams read out row "
                 "by row; needs frames in capture order)")
      ->capture_default_str();
}

PipelineOptions ParsedPipelineOptions(const ProcessSettings& settings) {
  PipelineOptions options = settings.options;
  options.sparse.init = ParseInitMode(settings.init);
  try {
    options.sparse.rolling_shutter = ParseRollingShutter(settings.rolling_shutter);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--rolling-shutter: ") + e.what());
  }
  options.run_dense = !settings.no_dense;
  if (settings.threads > 0) cv::setNumThreads(settings.threads);
  return options;
}

PipelineOptions WithKnownCalibration(PipelineOptions options, const ProcessSettings& settings,
                                     const Burst& burst, const char* command) {
  if (settings.calibration_file.empty()) return options;
  const std::string& file = settings.calibration_file;
  KnownCalibration known;
  known.mode = ParseKnownCalibrationMode(settings.calibration_mode);
  const ImportedCalibration imported = ReadCalibrationFile(file, burst.width(), burst.height());
  known.camera = imported.camera;
  known.lens = imported.lens;
  known.source = "file:" + file + " (" + imported.format + ")";
  if (imported.fit_max_error_px > 0.0)
    std::fprintf(stderr, "%s: %s: fitted to ha2016-d2u, max error %.3f px, RMS %.3f px\n", command,
                 file.c_str(), imported.fit_max_error_px, imported.fit_rms_error_px);
  for (const std::string& note : imported.notes)
    std::fprintf(stderr, "%s: %s: %s\n", command, file.c_str(), note.c_str());
  options.sparse.known = known;
  return options;
}

}  // namespace dfsm::tools
