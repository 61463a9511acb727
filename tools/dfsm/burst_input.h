// The bursts a dfsm command reads: a dfsm-burst/1 directory, or the footage
// people have: a video file (video_input.h), a folder of images or a glob of
// them (core/io/image_sequence.h).
#pragma once

#include <string>
#include <vector>

#include "core/io/burst.h"

namespace dfsm::tools {

// The burst `input` names: a dfsm-burst/1 directory (its `frames` centred on
// the reference, 0: all), else a video or a folder or glob of images (`start`
// frames skipped, then `frames`). Throws BurstError naming the input and the
// problem.
Burst ReadBurstInput(const std::string& input, int start, int frames);

// One window of an input: ReadBurstInput(input, start, frames).
struct BurstWindow {
  std::string input;
  int start = 0;
  int frames = 0;
  std::string Name() const;  // the input, with "[start, start + frames)" for a window
};

// `input` cut into consecutive windows of `frames` frames (a clip: a video,
// a folder or glob of images), or the whole input as one window where
// `frames` is 0 or the input is a burst directory. Throws BurstError as
// ReadBurstInput does.
std::vector<BurstWindow> WindowsOf(const std::string& input, int frames);

}  // namespace dfsm::tools
