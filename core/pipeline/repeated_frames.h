// Frames that repeat the one before them. A clip turned into frames at a
// constant rate repeats frames where the camera delivered fewer (a phone's
// variable frame rate, a 24 -> 30 fps conversion), and a stalled driver can
// hand out the same buffer twice. A repeated frame shows the scene from the
// pose of the frame it copies but stands at the next capture time, which the
// rolling shutter's path between frames cannot fit: a 640x480 phone burst
// with one frame repeated came out with f 30 % off and depth 12 % off
// (docs/experiments/120-repeated-frames.md). The pipeline leaves them out and
// takes the gap at the capture times (io/frame_times.h).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

struct RepeatedFramesOptions {
  // Frame i repeats frame i - 1 when their mean absolute difference (grey
  // levels) is below max_ratio times the burst's typical difference between
  // neighbours (the 75th percentile: half the frames may be repeats) and
  // below max_difference. Distinct frames differ by their noise alone (1-3
  // grey levels) and by the tremor's motion over texture; a repeat by nothing
  // or its recompression. max_ratio 0: no frame is a repeat.
  double max_ratio = 0.1;
  double max_difference = 1.0;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

// For each frame (8-bit gray, one size), the index of the earlier frame whose
// image it repeats (the first of a run of repeats), or -1. The frame
// `reference` is never a repeat: in a run that holds it, the reference stands
// for the run and the others repeat it.
std::vector<int> FindRepeatedFrames(const std::vector<cv::Mat>& gray, int reference,
                                    const RepeatedFramesOptions& options = {});

}  // namespace dfsm
