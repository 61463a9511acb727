// How far a burst's relief depends on the lens model
// (SparseReconstruction::lens_relief_shift, docs/experiments/124-lens-relief-shift.md).
#pragma once

#include <vector>

#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/feature_tracks.h"

namespace dfsm {

// The tracks of `use` adjusted again from the adjusted `state` with k1 alone
// (k2 held at 0, one warm adjustment with `options`), then the median over
// them of |b / (a w_j)|, where w' = a w + b fits the second adjustment's
// inverse depths to the first's: a common scale is free, an offset is relief.
// -1 where the fit is undefined (fewer than two tracks, a degenerate or
// reversed scale).
double LensReliefShift(const FeatureTracks& tracks, const std::vector<bool>& use,
                       const SparseState& state, BundleAdjustmentOptions options);

}  // namespace dfsm
