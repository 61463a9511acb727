// Frames of a generated scene with a known answer (core/synth): one handheld
// burst rendered at Open() and played in a loop like a camera, with the
// ground truth (calibration, poses) in the provenance of every grabbed burst.
// The loop's seam is a discontinuity, so a grabbed burst is always a run of
// the rendered one and its truth applies frame by frame.
#pragma once

#include <chrono>
#include <vector>

#include "daemon/capture/capture_service.h"
#include "daemon/capture/frame_source.h"

namespace dfsm::capture {

class SyntheticSource : public FrameSource {
 public:
  // Size from the config (default 640x360), rate from the config (default 30
  // fps), colour unless keep_color is off.
  explicit SyntheticSource(const CaptureConfig& config, int frames = 30);

  void Open() override;
  void Close() override;
  ReadResult Read(FrameSlot& slot, std::chrono::milliseconds timeout) override;
  SourceDescription Describe() const override;

 private:
  const CaptureConfig config_;
  const int frame_count_;
  std::vector<cv::Mat> gray_, color_;
  nlohmann::json truth_;
  size_t next_ = 0;
  bool seam_ = false;
  std::chrono::steady_clock::time_point due_;
};

}  // namespace dfsm::capture
