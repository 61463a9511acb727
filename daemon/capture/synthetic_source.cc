#include "daemon/capture/synthetic_source.h"

#include <opencv2/imgproc.hpp>
#include <thread>

#include "core/synth/burst_synthesizer.h"

namespace dfsm::capture {

SyntheticSource::SyntheticSource(const CaptureConfig& config, int frames)
    : config_(config), frame_count_(frames) {}

void SyntheticSource::Open() {
  if (!gray_.empty()) {  // rendered once; a reopen only restarts the loop
    next_ = 0;
    seam_ = false;
    due_ = std::chrono::steady_clock::now();
    return;
  }
  SynthOptions options;
  options.width = config_.width > 0 ? config_.width : 640;
  options.height = config_.height > 0 ? config_.height : 360;
  options.frames = frame_count_;
  options.color = config_.keep_color;
  SynthBurst burst;
  try {
    burst = SynthesizeBurst(options);
  } catch (const std::invalid_argument& e) {
    throw SourceError(SourceError::Kind::kConfig, std::string("synthetic: ") + e.what());
  }
  for (const cv::Mat& frame : burst.frames) {
    if (frame.channels() == 3) {
      color_.push_back(frame);
      gray_.emplace_back();
      cv::cvtColor(frame, gray_.back(), cv::COLOR_BGR2GRAY);
    } else {
      gray_.push_back(frame);
    }
  }
  nlohmann::json poses = nlohmann::json::array();
  for (const Pose& pose : burst.truth.poses) poses.push_back(ToJson(pose));
  truth_ = {{"camera", ToJson(burst.truth.camera)},
            {"poses", poses},
            {"options", burst.manifest.source.value("synthetic", nlohmann::json())}};
  next_ = 0;
  seam_ = false;
  due_ = std::chrono::steady_clock::now();
}

void SyntheticSource::Close() {}

ReadResult SyntheticSource::Read(FrameSlot& slot, std::chrono::milliseconds timeout) {
  if (gray_.empty()) throw SourceError(SourceError::Kind::kIo, "synthetic: read before open");
  if (due_ > std::chrono::steady_clock::now() + timeout) {
    std::this_thread::sleep_for(timeout);
    return ReadResult::kTimeout;
  }
  std::this_thread::sleep_until(due_);
  gray_[next_].copyTo(slot.gray);
  if (color_.empty())
    slot.color.release();
  else
    color_[next_].copyTo(slot.color);
  const auto now = std::chrono::steady_clock::now();
  slot.timestamp_ns = MonotonicNs(now);
  slot.source_sequence = static_cast<int64_t>(next_);
  slot.dropped_before = 0;
  slot.discontinuity = seam_;
  seam_ = false;
  const double fps = config_.fps > 0 ? config_.fps : 30.0;
  due_ += std::chrono::nanoseconds(static_cast<int64_t>(1e9 / fps));
  if (due_ < now) due_ = now;
  if (++next_ == gray_.size()) {
    next_ = 0;
    seam_ = true;
  }
  return ReadResult::kFrame;
}

SourceDescription SyntheticSource::Describe() const {
  SourceDescription d;
  d.kind = "synthetic";
  d.device = "synthetic";
  d.driver = "core/synth";
  d.format = color_.empty() ? "gray8" : "bgr8";
  if (!gray_.empty()) {
    d.width = gray_[0].cols;
    d.height = gray_[0].rows;
  }
  d.fps = config_.fps > 0 ? config_.fps : 30.0;
  d.color = !color_.empty();
  // source_sequence_first/last of a burst index these poses.
  d.details = {{"ground_truth", truth_}};
  return d;
}

}  // namespace dfsm::capture
