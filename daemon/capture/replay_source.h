// Plays recorded bursts (dfsm-burst/1) as if a camera delivered them: one burst
// directory, or a directory whose subdirectories are bursts (played in name
// order), looped forever. Frames come at the recorded rate (from the
// manifest's timestamps), at a fixed rate, or as fast as they are read.
//
// ReplayLoop::kRestart: moving from a burst's last frame back to its first (or
// to the next burst) is reported as a discontinuity, so no grabbed burst ever
// spans the seam. ReplayLoop::kReverse: each burst plays forward, then
// backward, and so on, a continuous stream as a camera gives (a burst of the
// last N frames is always at hand); with several bursts, the next one starts
// (a seam) each time the current one is back at its first frame.
// Memory: the decoded frames of one burst at a time.
#pragma once

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "daemon/capture/frame_source.h"

namespace dfsm::capture {

enum class ReplayLoop { kRestart, kReverse };

// "restart" | "reverse"; the choices of the capture.replay_loop key.
const char* ReplayLoopName(ReplayLoop loop);
// Throws std::invalid_argument naming the value and the choices.
ReplayLoop ParseReplayLoop(const std::string& name);

class ReplaySource : public FrameSource {
 public:
  // fps > 0: that rate; fps == 0: the recorded rate (30 fps where timestamps
  // are missing); fps < 0: no pacing at all.
  ReplaySource(std::filesystem::path root, double fps, bool keep_color = true,
               ReplayLoop loop = ReplayLoop::kRestart);

  // The bursts under `root`, in play order. Throws SourceError(kConfig) when
  // there are none.
  static std::vector<std::filesystem::path> FindBursts(const std::filesystem::path& root);

  void Open() override;
  void Close() override;
  ReadResult Read(FrameSlot& slot, std::chrono::milliseconds timeout) override;
  SourceDescription Describe() const override;

 private:
  struct Frame {
    cv::Mat gray;
    cv::Mat color;            // empty for gray bursts
    int64_t interval_ns = 0;  // until the next frame, at the recorded rate
  };
  void LoadBurst(size_t index);
  // Moves next_frame_ on; returns the recorded interval to the frame it chose.
  int64_t Advance();

  const std::filesystem::path root_;
  const double fps_;
  const bool keep_color_;
  const ReplayLoop loop_;
  std::vector<std::filesystem::path> bursts_;
  size_t burst_index_ = 0;
  std::vector<Frame> frames_;
  size_t next_frame_ = 0;
  bool seam_ = false;    // the next frame starts a new pass
  bool forward_ = true;  // kReverse: the direction of play
  bool open_ = false;
  std::chrono::steady_clock::time_point due_;
};

}  // namespace dfsm::capture
