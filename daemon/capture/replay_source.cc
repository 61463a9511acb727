#include "daemon/capture/replay_source.h"

#include <algorithm>
#include <stdexcept>
#include <thread>

#include "core/io/burst.h"
#include "core/io/image_decode.h"

namespace dfsm::capture {
namespace fs = std::filesystem;

namespace {

constexpr int64_t kDefaultIntervalNs = 1000000000 / 30;

}  // namespace

const char* ReplayLoopName(ReplayLoop loop) {
  return loop == ReplayLoop::kReverse ? "reverse" : "restart";
}

ReplayLoop ParseReplayLoop(const std::string& name) {
  if (name == "restart") return ReplayLoop::kRestart;
  if (name == "reverse") return ReplayLoop::kReverse;
  throw std::invalid_argument("replay loop must be \"restart\" or \"reverse\", not \"" + name +
                              "\"");
}

ReplaySource::ReplaySource(fs::path root, double fps, bool keep_color, ReplayLoop loop)
    : root_(std::move(root)), fps_(fps), keep_color_(keep_color), loop_(loop) {}

std::vector<fs::path> ReplaySource::FindBursts(const fs::path& root) {
  std::error_code ec;
  if (!fs::is_directory(root, ec))
    throw SourceError(SourceError::Kind::kConfig,
                      "replay: " + root.string() + " is not a directory");
  if (fs::exists(root / "manifest.json", ec)) return {root};
  std::vector<fs::path> bursts;
  for (const auto& entry : fs::directory_iterator(root, ec))
    if (entry.is_directory() && fs::exists(entry.path() / "manifest.json")) bursts.push_back(entry);
  if (ec)
    throw SourceError(SourceError::Kind::kConfig,
                      "replay: cannot list " + root.string() + ": " + ec.message());
  if (bursts.empty())
    throw SourceError(
        SourceError::Kind::kConfig,
        "replay: " + root.string() + " holds neither manifest.json nor burst directories with one");
  std::sort(bursts.begin(), bursts.end());
  return bursts;
}

void ReplaySource::LoadBurst(size_t index) {
  const fs::path& dir = bursts_[index];
  BurstManifest manifest;
  try {
    manifest = ReadBurstManifest(dir);
  } catch (const BurstError& e) {
    throw SourceError(SourceError::Kind::kConfig, std::string("replay: ") + e.what());
  }
  if (!frames_.empty() &&
      (manifest.width != frames_[0].gray.cols || manifest.height != frames_[0].gray.rows))
    throw SourceError(SourceError::Kind::kConfig,
                      "replay: " + dir.string() + " is " + std::to_string(manifest.width) + "x" +
                          std::to_string(manifest.height) +
                          ", unlike the bursts before it: a replay plays one size");
  std::vector<Frame> frames(manifest.frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    const fs::path file = dir / manifest.frames[i].file;
    cv::Mat image;
    try {
      image = ReadImageFile(file);
    } catch (const std::runtime_error& e) {
      throw SourceError(SourceError::Kind::kConfig,
                        std::string("replay: cannot decode ") + e.what());
    }
    if (image.cols != manifest.width || image.rows != manifest.height)
      throw SourceError(SourceError::Kind::kConfig, "replay: " + file.string() + " is not " +
                                                        std::to_string(manifest.width) + "x" +
                                                        std::to_string(manifest.height));
    try {
      frames[i].gray = ToGray8(image);
    } catch (const BurstError& e) {
      throw SourceError(SourceError::Kind::kConfig, "replay: " + file.string() + ": " + e.what());
    }
    if (keep_color_ && image.channels() > 1) frames[i].color = ToBgr8(image);
    if (i + 1 < frames.size()) {
      const int64_t delta = manifest.frames[i + 1].timestamp_ns - manifest.frames[i].timestamp_ns;
      frames[i].interval_ns = delta > 0 ? delta : kDefaultIntervalNs;
    }
  }
  // The step back to the first frame takes one typical interval.
  if (frames.size() > 1) {
    std::vector<int64_t> intervals;
    for (size_t i = 0; i + 1 < frames.size(); ++i) intervals.push_back(frames[i].interval_ns);
    std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
    frames.back().interval_ns = intervals[intervals.size() / 2];
  } else if (!frames.empty()) {
    frames.back().interval_ns = kDefaultIntervalNs;
  }
  frames_ = std::move(frames);
  burst_index_ = index;
}

void ReplaySource::Open() {
  bursts_ = FindBursts(root_);
  frames_.clear();
  LoadBurst(0);
  next_frame_ = 0;
  seam_ = false;
  forward_ = true;
  open_ = true;
  due_ = std::chrono::steady_clock::now();
}

void ReplaySource::Close() {
  open_ = false;
  frames_.clear();
}

ReadResult ReplaySource::Read(FrameSlot& slot, std::chrono::milliseconds timeout) {
  if (!open_) throw SourceError(SourceError::Kind::kIo, "replay: read before open");
  const auto now = std::chrono::steady_clock::now();
  if (fps_ >= 0) {
    if (due_ > now + timeout) {
      std::this_thread::sleep_for(timeout);
      return ReadResult::kTimeout;
    }
    std::this_thread::sleep_until(due_);
  }
  const Frame& frame = frames_[next_frame_];
  frame.gray.copyTo(slot.gray);
  if (frame.color.empty())
    slot.color.release();
  else
    frame.color.copyTo(slot.color);
  const auto shown = std::chrono::steady_clock::now();
  slot.timestamp_ns = MonotonicNs(shown);
  slot.source_sequence = static_cast<int64_t>(next_frame_);
  slot.dropped_before = 0;
  slot.discontinuity = seam_;
  seam_ = false;

  // Pace from the schedule, not from the wake-up, so the rate does not drift;
  // after a stall longer than one interval, restart the schedule instead of
  // bursting to catch up.
  const int64_t recorded_ns = Advance();
  const int64_t interval_ns = fps_ > 0 ? static_cast<int64_t>(1e9 / fps_) : recorded_ns;
  due_ += std::chrono::nanoseconds(interval_ns);
  if (due_ < shown) due_ = shown;
  return ReadResult::kFrame;
}

int64_t ReplaySource::Advance() {
  const size_t shown = next_frame_;
  if (loop_ == ReplayLoop::kReverse && frames_.size() > 1) {
    if (forward_ && shown + 1 == frames_.size()) {
      forward_ = false;
    } else if (!forward_ && shown == 0) {
      forward_ = true;
      if (bursts_.size() > 1) {
        const int64_t interval_ns = frames_.back().interval_ns;
        LoadBurst((burst_index_ + 1) % bursts_.size());
        next_frame_ = 0;
        seam_ = true;
        return interval_ns;
      }
    }
    next_frame_ = forward_ ? shown + 1 : shown - 1;
    // The recorded interval between the two frames, whichever way.
    return frames_[std::min(shown, next_frame_)].interval_ns;
  }
  const int64_t interval_ns = frames_[shown].interval_ns;
  if (++next_frame_ == frames_.size()) {
    next_frame_ = 0;
    seam_ = true;
    if (bursts_.size() > 1) LoadBurst((burst_index_ + 1) % bursts_.size());
  }
  return interval_ns;
}

SourceDescription ReplaySource::Describe() const {
  SourceDescription d;
  d.kind = "replay";
  d.device = root_.string();
  d.driver = "replay";
  d.format = "png";
  d.live = false;
  if (!frames_.empty()) {
    d.width = frames_[0].gray.cols;
    d.height = frames_[0].gray.rows;
    d.color = !frames_[0].color.empty();
  }
  if (fps_ > 0) {
    d.fps = fps_;
  } else if (!frames_.empty() && frames_[0].interval_ns > 0 && fps_ == 0) {
    d.fps = 1e9 / static_cast<double>(frames_[0].interval_ns);
  }
  nlohmann::json bursts = nlohmann::json::array();
  for (const auto& burst : bursts_) bursts.push_back(burst.string());
  d.details = {{"bursts", bursts},
               {"playing", bursts_.empty() ? std::string() : bursts_[burst_index_].string()},
               {"pacing", fps_ > 0    ? "fixed"
                          : fps_ == 0 ? "recorded"
                                      : "unpaced"}};
  return d;
}

}  // namespace dfsm::capture
