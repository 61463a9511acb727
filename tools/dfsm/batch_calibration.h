// dfsm batch --calibrate-first: the batch's bursts adjusted jointly
// (core/sparse/joint_adjustment.h) before any is processed, so that each
// burst's depth starts from the camera all of them observe, as a prior checked
// against the burst (a burst of another camera is told by its fit, as a
// calibration file's is). DIR/calibration/ keeps calibration.json,
// calibration.yaml and joint.json; a later run into DIR (resumed, or another
// shard) takes the camera from there instead of adjusting again.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "core/sparse/sparse_reconstruction.h"
#include "tools/dfsm/batch_inputs.h"
#include "tools/dfsm/batch_runner.h"

namespace dfsm::tools {

// The sparse stage of `item` alone, as the pipeline runs it (at most `max_frames` of a burst or
// tar; a tar extracted into `scratch`, removed after): its tracks and own calibration, where a
// joint adjustment or a fusion of several bursts starts (dfsm calibrate, --calibrate-first). Throws
// BurstError or ReconstructionError naming the problem.
SparseReconstruction ReconstructAlone(const BatchItem& item, int max_frames,
                                      const PipelineOptions& pipeline,
                                      const std::filesystem::path& scratch);

// The prior of the joint calibration of `items` (all of the batch's, every
// shard alike) of the image size most of them have: its answer's camera
// (core/sparse/calibration_choice.h: the joint one, or the fusion of the same
// bursts), as wide as its sigma; nullopt where none could be made, or the
// joint camera answers and has no uncertainty or is degenerate. `said` gets
// one line for the user either way.
std::optional<KnownCalibration> CalibrateFirst(const std::vector<BatchItem>& items,
                                               const BatchRunOptions& options, std::string* said);

}  // namespace dfsm::tools
