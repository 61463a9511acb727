// A frame source: one device (or file set) that delivers frames one at a time
// into buffers it does not own. The capture thread is its only user, so a
// source needs no locking of its own; everything about threads, rings and
// reconnection lives in the service.
#pragma once

#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>

namespace dfsm::capture {

// Why a source failed; the service decides from the kind whether to reopen at
// once (kIo), back off until the device returns (kGone) or report a
// configuration that will not work until someone changes it (kConfig).
class SourceError : public std::runtime_error {
 public:
  enum class Kind { kConfig, kGone, kIo };
  SourceError(Kind kind, const std::string& what) : std::runtime_error(what), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

// Where a source writes one frame. The buffers belong to the ring and are
// reused frame after frame: a source fills them with create()/copyTo(), which
// reallocate only when the size or type changes.
struct FrameSlot {
  cv::Mat gray;                 // CV_8UC1, always filled
  cv::Mat color;                // CV_8UC3 BGR, or empty when the source has no colour
  int64_t timestamp_ns = 0;     // CLOCK_MONOTONIC
  int64_t source_sequence = 0;  // the driver's sequence, or the replayed frame's index
  // Frames the source knows were lost just before this one (gaps in the
  // driver's sequence, buffers flagged with errors).
  uint64_t dropped_before = 0;
  // This frame does not continue the previous one although nothing was lost
  // (a replay looping back to its first frame, or moving to the next burst).
  bool discontinuity = false;
};

// FrameSlot::timestamp_ns of a steady_clock time: steady_clock is
// CLOCK_MONOTONIC on Linux with libstdc++, the clock of the drivers' timestamps.
inline int64_t MonotonicNs(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

// What the source negotiated; the service copies it into Status() and into the
// provenance of every burst.
struct SourceDescription {
  std::string kind;  // "v4l2", "libcamera", "replay", "synthetic"
  std::string device, driver, card;
  std::string format;  // fourcc, libcamera pixel format, or "png"
  int width = 0, height = 0;
  double fps = 0.0;
  bool color = false;
  // A live device loses a frame that is not read in time; a recording does
  // not, so the service may make it wait for a burst reader that fell behind
  // instead of overwriting frames the burst still needs.
  bool live = true;
  nlohmann::json details = nlohmann::json::object();  // source-specific provenance
};

enum class ReadResult { kFrame, kTimeout };

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Opens and starts streaming. Throws SourceError.
  virtual void Open() = 0;
  // Stops streaming and releases the device; safe to call when not open.
  virtual void Close() = 0;
  // Waits at most `timeout` for the next frame and writes it into `slot`.
  // Throws SourceError when the device fails; the service then closes it.
  virtual ReadResult Read(FrameSlot& slot, std::chrono::milliseconds timeout) = 0;
  // Valid after a successful Open().
  virtual SourceDescription Describe() const = 0;
  // Freezes automatic exposure, white balance and focus while a burst is being
  // taken (where the device has such controls), and releases them again.
  virtual void HoldControls(bool hold) { (void)hold; }
};

}  // namespace dfsm::capture
