// A burst from a video file (MP4, MOV, MKV, AVI, WebM), decoded by the video
// module dfsm-video.so, which is loaded only here (video/video_module.h).
#pragma once

#include <string>

#include "core/io/burst.h"

namespace dfsm::tools {

// Whether `input` names a video file: a regular file with a video extension.
bool IsVideoFile(const std::string& input);

// `frames` frames of the video from frame `start` (0: all from there), the
// first read the reference, as a folder of images gives them. Throws
// BurstError naming the file and the problem: the module missing, a
// container or codec it cannot read, too few frames, frames of mixed sizes,
// a variable frame rate.
Burst ReadVideoBurst(const std::string& input, int start, int frames);

// The frames the video holds (decoded through, not kept). Throws BurstError
// as ReadVideoBurst does.
int CountVideoFrames(const std::string& input);

}  // namespace dfsm::tools
