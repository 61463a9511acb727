// dfsm-video.so: the video module (video_module.h).
#include "tools/dfsm/video/video_module.h"

#include <opencv2/imgproc.hpp>
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
  cv::Mat frame, gray;
  int index = 0;
  for (; request.frames == 0 || index < request.start + request.frames; ++index) {
    if (request.count_only || index < request.start) {
      if (!capture.grab()) break;
      continue;
    }
    if (request.frames == 0 && request.max_frames > 0 &&
        static_cast<int>(out->gray.size()) == request.max_frames) {
      out->error = "has more than " + std::to_string(request.max_frames) + " frames from frame " +
                   std::to_string(request.start) +
                   "; a burst is 10-30: give --frames N, or --windows N to cut it into bursts";
      return;
    }
    if (!capture.read(frame) || frame.empty()) break;
    if (frame.type() != CV_8UC3) {
      out->error = "frame " + std::to_string(index) + " decodes to an unexpected pixel type";
      return;
    }
    if (!out->gray.empty() && frame.size() != out->gray.front().size()) {
      out->error = "frame " + std::to_string(index) + " is " + std::to_string(frame.cols) + "x" +
                   std::to_string(frame.rows) + ", the first " +
                   std::to_string(out->gray.front().cols) + "x" +
                   std::to_string(out->gray.front().rows) + ": frames of mixed sizes";
      return;
    }
    if (out->gray.empty()) out->first_bgr = frame.clone();
    cv::cvtColor(frame, gray, cv::COLOR_BGR2GRAY);
    out->gray.push_back(gray.clone());
    out->timestamps_ns.push_back(
        static_cast<int64_t>(capture.get(cv::CAP_PROP_POS_MSEC) * 1e6 + 0.5));
  }
  out->total = index;
  if (!request.count_only && out->gray.empty())
    out->error = index == 0 ? "no frame could be decoded (an unsupported codec?)"
                            : "has " + std::to_string(index) + " frames, none from frame " +
                                  std::to_string(request.start) + " on";
}

}  // namespace
}  // namespace dfsm::tools

extern "C" __attribute__((visibility("default"))) void dfsm_read_video_v2(
    const char* path, const dfsm::tools::VideoReadRequest* request,
    dfsm::tools::VideoFrames* frames) {
  try {
    dfsm::tools::ReadVideo(path, *request, frames);
  } catch (const std::exception& e) {  // OpenCV's and FFmpeg's errors stay inside
    frames->error = std::string("cannot be decoded: ") + e.what();
  }
}
