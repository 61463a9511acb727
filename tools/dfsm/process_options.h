// The pipeline options a user gives on the command line, shared by `dfsm
// process` (one burst) and `dfsm batch` (many): one grammar, one meaning.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "core/io/burst.h"
#include "core/pipeline/pipeline.h"

namespace dfsm::tools {

struct ProcessSettings {
  PipelineOptions options;  // --grid, --planes, --max-iterations land here directly
  std::string init;
  std::string rolling_shutter;
  std::string calibration_file;
  std::string calibration_mode;
  int frames = 0;
  bool no_dense = false;
  int threads = 0;

  ProcessSettings();
};

// Adds --init, --frames, --grid, --planes, --no-dense, --threads,
// --max-iterations, --calibration, --calibration-mode and --rolling-shutter
// to `app`, writing into `settings`.
void AddProcessOptions(CLI::App& app, ProcessSettings* settings);

// The pipeline options `settings` give, checked: --init, --rolling-shutter,
// --no-dense applied, the thread count set. Throws UsageError naming the
// option.
PipelineOptions ParsedPipelineOptions(const ProcessSettings& settings);

// `options` with the known calibration of --calibration read for `burst`'s
// image size (unchanged without one). Notes on the file (a fitted model)
// are printed to stderr with `command` in front. Throws
// CalibrationFileError naming the file and the problem.
PipelineOptions WithKnownCalibration(PipelineOptions options, const ProcessSettings& settings,
                                     const Burst& burst, const char* command);

}  // namespace dfsm::tools
