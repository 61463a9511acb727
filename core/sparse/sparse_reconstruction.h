// The sparse half of the pipeline: grided features -> rotations -> rank-1
// initialization (or the naive one) -> self-calibrating bundle adjustment.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/io/burst.h"
#include "core/io/result.h"
#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/grided_features.h"
#include "core/sparse/rank_one_init.h"
#include "core/sparse/rotation_init.h"

namespace dfsm {

// A burst the method cannot reconstruct; the message names the reason in
// measured terms (e.g. "insufficient parallax: median track motion 0.04 px").
class ReconstructionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class InitMode { kRankOne, kNaive };
InitMode ParseInitMode(const std::string& name);  // "rank1" | "naive"; throws std::invalid_argument
const char* InitModeName(InitMode mode);

struct SparseOptions {
  GridedFeatureOptions features;
  RankOneOptions rank_one;
  BundleAdjustmentOptions bundle_adjustment;
  InitMode init = InitMode::kRankOne;
  uint64_t naive_seed = 0;  // the naive init's random inverse depths
  int min_tracks = 20;
  double min_parallax_px = 0.15;  // median largest track motion below this: no depth to recover
  // After the adjustment, tracks whose reprojection error exceeds
  // max(this, 4 robust sigmas) are dropped and the adjustment is rerun, for at
  // most `outlier_rounds` rounds. 0.3 px, not ~1.5: measured on rendered
  // bursts (docs/sparse.md), the tracks between 0.3 and 1.5 px are corners on
  // depth edges, and keeping them costs 10-25 % of focal accuracy at VGA.
  double outlier_px = 0.3;
  int outlier_rounds = 3;
};

struct SparseReconstruction {
  FeatureTracks tracks;
  GridedFeatureStats feature_stats;
  SparseState state;          // camera, poses, inverse depths of every track
  std::vector<bool> inliers;  // tracks used by the final adjustment
  BundleAdjustmentSummary bundle_adjustment;
  RankOneResult rank_one;  // diagnostics of the initialization (rank1 mode)
  std::vector<std::pair<std::string, double>>
      timings_ms;  // features, rotation, rank1, bundle_adjustment

  // Inverse depths of the inlier tracks.
  std::vector<double> InlierInverseDepths() const;
};

// Throws ReconstructionError for bursts that cannot be reconstructed.
SparseReconstruction ReconstructSparse(const std::vector<cv::Mat>& gray_frames, int reference,
                                       const SparseOptions& options = {});

}  // namespace dfsm
