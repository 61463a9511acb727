// A rolling shutter's start for the adjustment. The rank-1 initialization
// assumes a global shutter; under a phone's readout and a degree of tremor its
// rotations are off by tenths of a degree (1080p, readout 0.6: 0.35 deg), and
// the adjustment from there settles in a wrong minimum (0.03-0.09 deg, the
// translation tens of degrees off). Moving every observation to where the
// frame's middle row would have seen it, by the rows' rotations alone (the
// rotation dominates a handheld readout's distortion and needs no depth),
// gives the rank-1 step tracks it can factorize; a few rounds of rectifying
// with its own rotations converge (0.35 -> 0.05 -> 0.014 -> 0.006 deg).
#pragma once

#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"
#include "core/sparse/feature_tracks.h"
#include "core/sparse/rank_one_init.h"

namespace dfsm {

// The tracks as a global shutter at each frame's middle row would have seen
// them: x -> R_i R_i(v)^T x for the observation of row v (core/camera/
// rolling_shutter.h), the reference's rows too. Observations the camera
// cannot map back (beyond its fold) are left as they are. `times`: the
// frames' capture times (SparseState::frame_times; empty: consecutive).
FeatureTracks RectifyRollingShutter(const FeatureTracks& tracks, const CameraModel& camera,
                                    const std::vector<Pose>& poses, double readout,
                                    const std::vector<double>& times = {});

// Rank-1 initialization on tracks rectified with `readout`, each round's
// rotations rectifying the next, while the rank-1 residual falls; `poses` is
// the first round's motion (the global-shutter rank-1 result or an
// adjustment's). The poses and inverse depths it returns are a start for the
// rolling-shutter adjustment on the original tracks.
RankOneResult RectifiedRankOneInit(const FeatureTracks& tracks, const CameraModel& camera,
                                   std::vector<Pose> poses, double readout, int rounds,
                                   const RankOneOptions& options = {},
                                   const std::vector<double>& times = {});

}  // namespace dfsm
