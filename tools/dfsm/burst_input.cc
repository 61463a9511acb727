#include "tools/dfsm/burst_input.h"

#include <filesystem>

#include "core/io/image_sequence.h"
#include "tools/dfsm/video_input.h"

namespace dfsm::tools {

Burst ReadBurstInput(const std::string& input, int start, int frames) {
  if (IsVideoFile(input)) return ReadVideoBurst(input, start, frames);
  std::error_code error;
  if (std::filesystem::is_regular_file(input, error))
    throw BurstError("'" + input +
                     "' is a file but not a video; give a video (MP4, MOV, MKV, AVI, WebM), a "
                     "dfsm-burst/1 directory, a folder of PNG or JPEG images, or a glob of them");
  if (!IsImageSequence(input)) {
    if (start > 0) throw BurstError("--start is for a folder or glob of images, not a burst");
    ReadBurstOptions read;
    read.max_frames = frames;
    return ReadBurst(input, read);
  }
  ImageSequenceOptions sequence;
  sequence.start = start;
  sequence.frames = frames;
  return ReadImageSequence(input, sequence);
}

std::string BurstWindow::Name() const {
  if (start == 0 && frames == 0) return input;
  return input + " [" + std::to_string(start) + ", " + std::to_string(start + frames) + ")";
}

std::vector<BurstWindow> WindowsOf(const std::string& input, int frames) {
  const bool video = IsVideoFile(input);
  if (frames == 0 || (!video && !IsImageSequence(input))) return {{input, 0, 0}};
  const int images =
      video ? CountVideoFrames(input) : static_cast<int>(ListImageSequence(input).size());
  std::vector<BurstWindow> windows;
  for (int start = 0; start + frames <= images; start += frames)
    windows.push_back({input, start, frames});
  if (windows.empty())
    throw BurstError("'" + input + "' holds " + std::to_string(images) +
                     (video ? " frames" : " images") + ", fewer than one window of " +
                     std::to_string(frames));
  return windows;
}

}  // namespace dfsm::tools
