// The interface between dfsm and its video module, dfsm-video.so: the frames
// of a video file, decoded by OpenCV's videoio (FFmpeg). dfsm loads the module
// only for a video input (video_input.h): videoio and FFmpeg bring about 190
// shared libraries and 0.17 s of start-up that no other input needs.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace dfsm::tools {

struct VideoReadRequest {
  int start = 0;            // frames skipped first
  int frames = 0;           // frames decoded from there (0: all, at most max_frames)
  int max_frames = 0;       // with frames 0: more than this is an error (0: no bound)
  bool count_only = false;  // keep nothing: count the frames (VideoFrames::total)
};

struct VideoFrames {
  std::vector<cv::Mat> gray;           // 8-bit, one size: what the pipeline works on
  cv::Mat first_bgr;                   // the first frame read in colour (the reference's)
  std::vector<int64_t> timestamps_ns;  // each frame's presentation time (0: none known)
  int total = 0;                       // frames in the video (count_only)
  double fps = 0.0;                    // the container's nominal rate
  std::string error;                   // empty: read; else what went wrong, for the user
};

// The module's one entry point (C linkage, for dlsym). The symbol carries the
// interface's version: the structs above cross the dlopen boundary as C++
// objects, so a change to them takes a new suffix, and a module of another
// build is refused by name instead of misread.
using ReadVideoFunction = void (*)(const char* path, const VideoReadRequest* request,
                                   VideoFrames* frames);
inline constexpr const char* kReadVideoSymbol = "dfsm_read_video_v2";

}  // namespace dfsm::tools
