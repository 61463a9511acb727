// How much depth a burst's motion can show. A small-motion burst's tracks
// move mostly by rotation, which carries no depth; what is left once each
// observation is turned back to the reference's orientation is the parallax,
// and the depth's precision is the tracking noise over it.
#pragma once

#include <vector>

#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/feature_tracks.h"

namespace dfsm {

struct Parallax {
  // Over the tracks used: each track's largest motion from the reference
  // with the frame's rotation taken out, pixels (the median and the 90th
  // percentile). The rolling shutter's row-to-row motion is not taken out.
  double median_px = 0.0;
  double p90_px = 0.0;
  // The farthest camera centre from the reference's over the median depth.
  double baseline_over_depth = 0.0;
  // sigma(z) / z at the median parallax for one observation of `noise_px`:
  // noise_px / median_px (a track seen in many frames does better).
  double relative_depth_sigma = 0.0;
};

// The parallax of `tracks` under `state` (camera, poses, inverse depths),
// over the tracks `use` marks; `noise_px`: the tracking noise per
// observation (the adjustment's RMS error).
Parallax MeasureParallax(const FeatureTracks& tracks, const std::vector<bool>& use,
                         const SparseState& state, double noise_px);

}  // namespace dfsm
