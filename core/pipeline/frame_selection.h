// The frames of a burst that the stages see, where some are left out: a
// repeat of the frame before it (repeated_frames.h), or a frame the tracker
// lost (GridedFeatureOptions::max_frame_track_loss). result.json still holds a
// pose for every frame the caller gave (CONTRACT.md section 3).
#pragma once

#include <vector>

#include "core/camera/pose.h"
#include "core/io/burst.h"

namespace dfsm {

// The burst of `frames` (indices into `burst`, ascending, its reference among
// them): their images, manifest entries and source indices, the reference at
// its place among them; source_indices name them in the manifest as stored.
// The Mats are shared with `burst`.
Burst SelectFrames(const Burst& burst, const std::vector<int>& frames);

// The pose at capture time `time` of a camera whose poses at `times`
// (ascending, two at least) are `poses`: rotation and translation taken
// linearly in time from the two nearest frames before and after it, or
// carried on from the two nearest where it lies outside them. A hand's
// tremor is smooth over the frame interval; a frame the tracker lost is
// usually blurred by a faster motion, so the pose is the motion's trend,
// not a measurement.
Pose PoseAtTime(const std::vector<double>& times, const std::vector<Pose>& poses, double time);

}  // namespace dfsm
