// The whole method on one burst: sparse reconstruction, then dense depth, and
// the dfsm-result/1 directory that reports it.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "core/dense/dense_depth.h"
#include "core/io/burst.h"
#include "core/io/progress.h"
#include "core/io/result.h"
#include "core/pipeline/depth_check.h"
#include "core/pipeline/photometric_compensation.h"
#include "core/pipeline/repeated_frames.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {

struct PipelineOptions {
  SparseOptions sparse;
  DenseOptions dense;
  bool run_dense = true;
  DepthCheckOptions depth_check;  // the dense map's check and verdict
  // Without a known calibration, a JPEG burst's EXIF 35 mm equivalent focal
  // length is a prior on f of this width (0: ignored). Nominal focal lengths,
  // digital crops and video modes make it approximate, hence wide.
  double exif_focal_sigma_percent = 5.0;
  PhotometricCompensationOptions photometric;
  // Frames that repeat the one before them are left out (repeated_frames.h).
  RepeatedFramesOptions repeated_frames;

  // Each part's Check() (the dense stage's where it runs): RunPipeline calls
  // it before any work, so that a bad option costs no seconds of it.
  void Check() const;
};

struct PipelineOutput {
  Result result;  // result.ok == false carries the reason in result.error
  std::optional<SparseReconstruction> sparse;
  std::optional<DenseDepth> dense;
};

// `options` without the dense stage, its sparse stage still refusing the
// cameras the dense stage could not invert where `options` runs it: the
// sparse stage of that run, as a trial of it (burst_length.h).
PipelineOptions SparseStageOf(PipelineOptions options);

// The sparse stage of `burst` as RunPipeline runs it (repeated frames and
// frames the tracker loses left out, exposure compensated, the frames'
// capture times, an EXIF prior), without the dense stage: the tracks and own
// calibration that a calibration over several bursts starts from, the same
// as a job of `dfsm process` or dfsmd would give. Throws std::invalid_argument
// for options out of range, ReconstructionError with the pipeline's reason
// where the burst fails.
SparseReconstruction ReconstructSparseStage(const Burst& burst, PipelineOptions options);

// Never throws for a burst the method cannot handle: the failure is reported in
// the returned result (status "failed" with a named reason). `progress` hears
// each lap of the stages as it ends (core/io/progress.h).
PipelineOutput RunPipeline(const Burst& burst, const PipelineOptions& options,
                           const ProgressCallback& progress = {});

// Writes result.json and every output file of a successful run into out_dir
// (created when needed): depth.tiff, depth.png, confidence.png, preview.png,
// points.ply, sparse_points.ply, calibration.json, calibration.yaml. A failed
// run writes result.json alone. Each file is written atomically.
void WritePipelineOutputs(const std::filesystem::path& out_dir, const Burst& burst,
                          PipelineOutput* output);

}  // namespace dfsm
