// Feature tracks of a burst: each track is one reference-frame corner followed
// through every frame. Invariant: every track has a position in every frame.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace dfsm {

struct FeatureTracks {
  int reference = 0;
  // pixels[frame].col(track): captured (distorted) pixel position of the track.
  std::vector<Eigen::Matrix2Xd> pixels;
  // Per track, the weight of its squared reprojection errors in the bundle
  // adjustment (1 / its noise variance, relative to the median track's);
  // empty: 1 each. The reweighting rounds set it (SparseOptions::
  // reweight_rounds, AdjustmentAttempt::weights).
  std::vector<double> weights;

  int num_frames() const { return static_cast<int>(pixels.size()); }
  int num_tracks() const { return pixels.empty() ? 0 : static_cast<int>(pixels[0].cols()); }
  double weight(int track) const { return weights.empty() ? 1.0 : weights[track]; }

  // Keeps the tracks whose flag is true, in order.
  FeatureTracks Select(const std::vector<bool>& keep) const;
  // Median over tracks of the largest displacement from the reference position.
  double MedianMaxDisplacement() const;
};

// How many tracks a per-track flag (kept, used, inlier) marks.
int CountUsed(const std::vector<bool>& use);

}  // namespace dfsm
