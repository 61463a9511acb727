// When a burst's frames were captured, in frame intervals, for the rolling
// shutter's path between frames (core/camera/rolling_shutter.h). A camera
// that drops a frame (USB bandwidth, a busy board) leaves a gap of two
// intervals between neighbours; taken as one, the rows' motion across it is
// halved, and a 640x480 phone burst missing one frame comes out with f 16 %
// off and depth 8 % off instead of 1 % and 3 %
// (docs/experiments/119-dropped-frames.md).
#pragma once

#include <vector>

#include "core/io/burst.h"

namespace dfsm {

// Each frame's capture time relative to the first, in frame intervals, from
// the manifest: the sequence numbers where they increase (a driver's count,
// gaps included), else the timestamps where they increase, divided by their
// median interval and rounded (jitter is not motion). Empty when the frames
// are consecutive, or when neither field increases (nothing to go by: the
// frames are taken as consecutive, as the pipeline always did).
std::vector<double> CaptureTimes(const BurstManifest& manifest);

// Frame `frame`'s capture time: times[frame], or its place in the burst
// where `times` is empty (consecutive frames).
inline double CaptureTime(const std::vector<double>& times, int frame) {
  return times.empty() ? static_cast<double>(frame) : times.at(frame);
}

// The frames missing between the first and the last of `times` (0 for empty).
int MissingFrames(const std::vector<double>& times);

}  // namespace dfsm
