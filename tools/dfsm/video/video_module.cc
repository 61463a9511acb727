// dfsm-video.so: the video module (video_module.h).
#include "tools/dfsm/video/video_module.h"

#include <opencv2/videoio.hpp>

namespace dfsm::tools {
namespace {

void ReadVideo(const char* path, const VideoReadRequest& request, VideoFrames* out) {
  cv::VideoCapture capture(path, cv::CAP_FFMPEG);
  if (!capture.isOpened()) {
    out->error = "cannot be opened as a video (an unknown container or codec, or a damaged file)";
    return;
  }
  out->fps = capture.get(cv::CAP_PROP_FPS);
  cv::Mat frame;
  int index = 0;
  for (; request.frames == 0 || index < request.start + request.frames; ++index) {
    if (request.count_only || index < request.start) {
      if (!capture.grab()) break;
      continue;
    }
    if (!capture.read(frame) || frame.empty()) break;
    if (frame.type() != CV_8UC3) {
      out->error = "frame " + std::to_string(index) + " decodes to an unexpected pixel type";
      return;
    }
    if (!out->bgr.empty() && frame.size() != out->bgr.front().size()) {
      out->error = "frame " + std::to_string(index) + " is " + std::to_string(frame.cols) + "x" +
                   std::to_string(frame.rows) + ", the first " +
                   std::to_string(out->bgr.front().cols) + "x" +
                   std::to_string(out->bgr.front().rows) + ": frames of mixed sizes";
      return;
    }
    out->bgr.push_back(frame.clone());
    out->timestamps_ns.push_back(
        static_cast<int64_t>(capture.get(cv::CAP_PROP_POS_MSEC) * 1e6 + 0.5));
  }
  out->total = index;
  if (!request.count_only && out->bgr.empty())
    out->error = index == 0 ? "no frame could be decoded (an unsupported codec?)"
                            : "has " + std::to_string(index) + " frames, none from frame " +
                                  std::to_string(request.start) + " on";
}

}  // namespace
}  // namespace dfsm::tools

extern "C" __attribute__((visibility("default"))) void dfsm_read_video(
    const char* path, const dfsm::tools::VideoReadRequest* request,
    dfsm::tools::VideoFrames* frames) {
  try {
    dfsm::tools::ReadVideo(path, *request, frames);
  } catch (const std::exception& e) {  // OpenCV's and FFmpeg's errors stay inside
    frames->error = std::string("cannot be decoded: ") + e.what();
  }
}
