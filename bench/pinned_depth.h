// An oracle for the sparse stage on data with a true depth map (TUM's Kinect,
// the generator's truth): the tracks' inverse depths set to the truth's and
// held, the poses (readout, velocities) adjusted to them under the stage's own
// camera. What it answers: how much worse do the tracks fit the true depths
// than their own minimum, under the model the adjustment uses; what does the
// dense stage make of a geometry anchored to the truth; and which camera do
// the tracks choose once their depths are right.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "core/dense/dense_depth.h"
#include "core/io/burst.h"
#include "core/pipeline/evaluation.h"
#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/feature_tracks.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {

struct PinnedDepthOptions {
  // A track is pinned only where the truth is flat around its reference
  // pixel: every truth pixel within this radius has depth within
  // flat_tolerance of the centre's. Corners sit on depth edges, where a
  // truth registered a few pixels off (TUM's Kinect: 1-4 px) gives the
  // other surface's depth.
  int flat_radius = 4;
  double flat_tolerance = 0.03;
  // Fewer pinned tracks than this: no answer.
  int min_tracks = 8;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

// A geometry's reprojection residuals split by direction, over the tracks
// `use` marks: RMS along each observation's parallax (the direction the
// observation moves as its track's inverse depth changes) and across it,
// pixels. A track's wrong depth moves its observations along their
// parallax only; what lies across is a misfit no depth removes
// (docs/experiments/041-parallax-range-on-real-tremor.md).
struct ParallaxSplit {
  double along_px = 0.0;
  double across_px = 0.0;
};
ParallaxSplit SplitByParallax(const FeatureTracks& tracks, const std::vector<bool>& use,
                              const SparseState& state);

struct PinnedDepth {
  // Per track of the stage: an inlier pinned to the truth. Both adjustments
  // below run over these tracks only.
  std::vector<bool> pinned_tracks;
  // Both adjusted from the stage's solution over the pinned tracks, the
  // camera held: `free` with each inverse depth free (the tracks' own
  // minimum), `pinned` with the truth's, one scale (the solution's median).
  SparseState free, pinned;
  // `pinned` adjusted once more with f, k1 and k2 free (the inverse depths
  // still held): the camera the tracks choose once their depths are right.
  SparseState camera_at_truth;
  double free_rms_px = 0.0, pinned_rms_px = 0.0;
  // Medians over the pinned tracks of each track's RMS error.
  double free_median_px = 0.0, pinned_median_px = 0.0;
  ParallaxSplit free_split, pinned_split;
  // The dense stage over the kept frames (not exposure-compensated) with
  // each geometry, scored against the truth under `mask`.
  DepthEvaluation free_depth, pinned_depth;
  // How far the near and the far pixels move against each other under the
  // pinned geometry: f x the farthest camera centre off the reference's axis
  // x the spread of the truth's inverse depth (2nd to 98th percentile over
  // the scored pixels, at the pinned scale), pixels. A depth map's error
  // times this range is the matching error it stands for
  // (docs/experiments/234-relief-is-the-parallaxs.md).
  double parallax_range_px = 0.0;

  int tracks() const;  // how many were pinned
};

// `truth`: depth (CV_32FC1, 0 = none) of the burst's reference, in the
// captured pixels; `sparse`: the stage run with `sparse_options` on `burst`.
// Empty where fewer than options.min_tracks tracks can be pinned.
std::optional<PinnedDepth> PinDepthToTruth(const Burst& burst, const cv::Mat& truth,
                                           const cv::Mat& mask, const SparseReconstruction& sparse,
                                           const SparseOptions& sparse_options,
                                           const DenseOptions& dense,
                                           const PinnedDepthOptions& options = {});

nlohmann::json ToJson(const PinnedDepth& pinned);

}  // namespace dfsm
