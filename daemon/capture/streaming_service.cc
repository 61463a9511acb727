#include "daemon/capture/streaming_service.h"

#include <algorithm>
#include <cmath>

#include "daemon/log/log.h"

namespace dfsm::capture {

namespace {

// How long one Read() may block: bounds how late Stop() and hold requests are
// noticed, independently of the (longer) frame timeout.
constexpr std::chrono::milliseconds kReadSlice{100};

}  // namespace

StreamingCaptureService::StreamingCaptureService(CaptureConfig config,
                                                 std::unique_ptr<FrameSource> source)
    : config_(std::move(config)), source_(std::move(source)), ring_(config_.ring_frames) {
  status_.source = config_.source;
  status_.ring_capacity = ring_.capacity();
}

StreamingCaptureService::~StreamingCaptureService() { Stop(); }

void StreamingCaptureService::Start() {
  if (thread_.joinable()) return;
  stop_ = false;
  thread_ = std::thread([this] { Run(); });
  running_ = true;
}

void StreamingCaptureService::Stop() {
  {
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  readers_cv_.notify_all();
  ring_.Wake();
  if (thread_.joinable()) thread_.join();
  running_ = false;
}

void StreamingCaptureService::SleepUnlessStopped(std::chrono::milliseconds duration) {
  std::unique_lock<std::mutex> lock(stop_mutex_);
  stop_cv_.wait_for(lock, duration, [this] { return stop_.load(); });
}

bool StreamingCaptureService::OpenSource() {
  // With a configured size the ring can be ready before the stream starts,
  // so the first frames do not wait for its memory.
  if (!ever_opened_ && config_.width > 0 && config_.height > 0)
    ring_.Preallocate(config_.width, config_.height, config_.keep_color);
  try {
    source_->Open();
  } catch (const SourceError& e) {
    std::lock_guard<std::mutex> lock(status_mutex_);
    // Once per outage, not at every retry of the backoff loop.
    if (!open_failed_ || status_.last_error != e.what())
      log::Warning(std::string("capture: cannot open ") + config_.source + ": " + e.what() +
                   "; retrying every " + std::to_string(config_.reconnect_backoff.count()) + " ms");
    status_.last_error = e.what();
    gone_ = e.kind() == SourceError::Kind::kGone;
    open_failed_ = true;
    return false;
  }
  const SourceDescription description = source_->Describe();
  ring_.Preallocate(description.width, description.height, description.color);
  std::lock_guard<std::mutex> lock(status_mutex_);
  description_ = description;
  status_.device = description.device;
  status_.driver = description.driver;
  status_.card = description.card;
  status_.format = description.format;
  status_.width = description.width;
  status_.height = description.height;
  status_.fps = description.fps;
  if (ever_opened_) {
    ++status_.reconnects;
    log::Notice("capture: reopened " + description.device + " (" + description.format + " " +
                std::to_string(description.width) + "x" + std::to_string(description.height) +
                "; reconnect " + std::to_string(status_.reconnects) + ")");
  } else {
    log::Info("capture: opened " + description.device + " (" + description.driver + ", " +
              description.format + " " + std::to_string(description.width) + "x" +
              std::to_string(description.height) + ")");
  }
  ever_opened_ = true;
  gone_ = false;
  open_failed_ = false;
  return true;
}

void StreamingCaptureService::LoseSource(const std::string& error, bool gone) {
  log::Write(gone ? log::Priority::kError : log::Priority::kWarning,
             std::string("capture: ") + (gone ? "device gone: " : "lost the stream: ") + error);
  source_->Close();
  holding_ = false;
  streaming_ = false;
  gone_ = gone;
  {
    std::lock_guard<std::mutex> lock(status_mutex_);
    status_.streaming = false;
    status_.last_error = error;
  }
  ring_.Wake();  // readers waiting for frames learn at once
}

void StreamingCaptureService::ApplyHoldRequest() {
  const bool want = holds_.load() > 0;
  if (want == holding_) return;
  try {
    source_->HoldControls(want);
  } catch (const SourceError& e) {
    // Not fatal: the burst is still consecutive, only exposure may drift.
    std::lock_guard<std::mutex> lock(status_mutex_);
    status_.last_error = e.what();
  }
  holding_ = want;
}

StreamingCaptureService::ReaderCursor::ReaderCursor(StreamingCaptureService& service, int64_t next)
    : service_(service) {
  std::lock_guard<std::mutex> lock(service_.readers_mutex_);
  position_ = service_.reader_cursors_.insert(next);
}

StreamingCaptureService::ReaderCursor::~ReaderCursor() {
  {
    std::lock_guard<std::mutex> lock(service_.readers_mutex_);
    service_.reader_cursors_.erase(position_);
  }
  service_.readers_cv_.notify_all();
}

void StreamingCaptureService::ReaderCursor::Advance(int64_t next) {
  {
    std::lock_guard<std::mutex> lock(service_.readers_mutex_);
    if (*position_ == next) return;
    service_.reader_cursors_.erase(position_);
    position_ = service_.reader_cursors_.insert(next);
  }
  service_.readers_cv_.notify_all();
}

void StreamingCaptureService::WaitForBurstReaders() {
  // No deadlock with the reader: the writer waits only while the frame the
  // reader needs next is in the ring, where CopyAtOrAfter() finds it at once.
  std::unique_lock<std::mutex> lock(readers_mutex_);
  while (!stop_ && !reader_cursors_.empty()) {
    const std::optional<int64_t> evicted = ring_.NextEvicted();
    if (!evicted || *evicted < *reader_cursors_.begin()) return;
    readers_cv_.wait_for(lock, kReadSlice);
  }
}

void StreamingCaptureService::Run() {
  bool open = false;
  bool discontinuity = false;  // the next frame follows a reopen
  bool first_frame = true;
  bool live = true;   // the open source's, read once per open under status_mutex_
  FrameSlot discard;  // written when readers pin every spare buffer
  auto last_frame = std::chrono::steady_clock::now();
  double measured_fps = 0.0;
  int64_t last_timestamp_ns = 0;

  while (!stop_) {
    if (!open) {
      if (!OpenSource()) {
        SleepUnlessStopped(config_.reconnect_backoff);
        continue;
      }
      open = true;
      {
        std::lock_guard<std::mutex> lock(status_mutex_);
        live = description_.live;
      }
      discontinuity = !first_frame;
      last_frame = std::chrono::steady_clock::now();
    }
    ApplyHoldRequest();
    if (!live) {
      WaitForBurstReaders();
      last_frame = std::chrono::steady_clock::now();
    }

    FrameSlot* slot = ring_.Staging();
    const bool dropping = slot == nullptr;
    if (dropping) slot = &discard;

    ReadResult result;
    try {
      result = source_->Read(*slot, std::min(config_.frame_timeout, kReadSlice));
    } catch (const SourceError& e) {
      const bool gone = e.kind() == SourceError::Kind::kGone;
      LoseSource(e.what(), gone);
      open = false;
      // An I/O error is usually cured by restarting the stream at once; a
      // device that went away needs time to come back.
      if (gone || e.kind() == SourceError::Kind::kConfig)
        SleepUnlessStopped(config_.reconnect_backoff);
      continue;
    }
    const auto now = std::chrono::steady_clock::now();
    if (result == ReadResult::kTimeout) {
      if (now - last_frame >= config_.frame_timeout) {
        LoseSource(status_.device + ": no frame for " +
                       std::to_string(config_.frame_timeout.count()) + " ms; reopening",
                   false);
        open = false;
      }
      continue;
    }
    last_frame = now;
    // A discontinuity within the source (a stream restarted in place, a
    // replay's next recording) changes its provenance (the count of restarts,
    // the recording playing): the bursts from now on report the new one.
    if (slot->discontinuity) {
      SourceDescription refreshed = source_->Describe();
      std::lock_guard<std::mutex> lock(status_mutex_);
      description_.details = std::move(refreshed.details);
    }

    int64_t sequence = next_sequence_ + static_cast<int64_t>(slot->dropped_before);
    if (!first_frame && (discontinuity || slot->discontinuity) && slot->dropped_before == 0)
      ++sequence;  // nothing was lost, but the frames do not follow each other
    if (first_frame) sequence = 0;
    next_sequence_ = sequence + 1;
    first_frame = false;
    discontinuity = false;
    if (!dropping) ring_.Publish(sequence);

    if (last_timestamp_ns > 0 && slot->timestamp_ns > last_timestamp_ns &&
        slot->dropped_before == 0) {
      const double fps = 1e9 / static_cast<double>(slot->timestamp_ns - last_timestamp_ns);
      measured_fps = measured_fps == 0.0 ? fps : 0.9 * measured_fps + 0.1 * fps;
    }
    last_timestamp_ns = slot->timestamp_ns;

    const bool was_streaming = streaming_.exchange(true);
    {
      std::lock_guard<std::mutex> lock(status_mutex_);
      ++status_.frames_captured;
      status_.frames_dropped += slot->dropped_before + (dropping ? 1 : 0);
      status_.streaming = true;
      status_.last_frame_monotonic_ns = slot->timestamp_ns;
      if (!was_streaming) status_.last_error.clear();
      if (description_.fps <= 0.0) status_.fps = measured_fps;
    }
    if (!was_streaming) ring_.Wake();
  }
  source_->Close();
  streaming_ = false;
  std::lock_guard<std::mutex> lock(status_mutex_);
  status_.streaming = false;
}

CaptureStatus StreamingCaptureService::Status() const {
  std::lock_guard<std::mutex> lock(status_mutex_);
  CaptureStatus status = status_;
  status.ring_fill = ring_.Fill();
  return status;
}

std::optional<CapturedFrame> StreamingCaptureService::LatestFrame() const {
  return ring_.CopyNewest();
}

CaptureService::Burst StreamingCaptureService::GrabBurst(int count, BurstWhen when,
                                                         std::chrono::milliseconds timeout) {
  if (count < 1 || count > ring_.capacity())
    throw CaptureUnavailable("a burst of " + std::to_string(count) +
                             " frames does not fit the capture ring of " +
                             std::to_string(ring_.capacity()) + " frames (ring_frames)");
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  const auto last_error = [this] {
    std::lock_guard<std::mutex> lock(status_mutex_);
    return status_.last_error;
  };
  if (stop_ || !running_)
    throw CaptureUnavailable("capture is not running (Start() was not called)");
  if (when == BurstWhen::kLast && !streaming_) {
    const std::string error = last_error();
    throw CaptureUnavailable("capture is not streaming" + (error.empty() ? "" : ": " + error));
  }

  struct HoldGuard {
    std::atomic<int>& holds;
    explicit HoldGuard(std::atomic<int>& h) : holds(h) { ++holds; }
    ~HoldGuard() { --holds; }
  } hold(holds_);

  int64_t next = 0;
  const auto newest = ring_.NewestSequence();
  if (newest) {
    if (when == BurstWhen::kLast)
      next = std::max(*ring_.NewestRunStart(), *newest - count + 1);
    else
      next = *newest + 1;
  }

  ReaderCursor cursor(*this, next);
  std::vector<CapturedFrame> got;
  got.reserve(static_cast<size_t>(count));
  int gaps = 0;
  // A device that cannot even be opened will not deliver before the timeout
  // is likely to pass: say so at once.
  const auto abort = [this] {
    return stop_.load() || (!streaming_.load() && (gone_.load() || open_failed_.load()));
  };
  while (static_cast<int>(got.size()) < count) {
    // Checked here too: a reader slower than the writer finds a frame at once
    // every time (after a gap) and would never wait for the deadline.
    std::optional<CapturedFrame> frame;
    if (std::chrono::steady_clock::now() < deadline)
      frame = ring_.CopyAtOrAfter(next, deadline, abort);
    if (!frame) {
      if (stop_) throw CaptureUnavailable("capture stopped while taking a burst");
      const std::string error = last_error();
      if (!streaming_ && gone_) throw CaptureUnavailable("capture device gone: " + error);
      if (!streaming_ && open_failed_)
        throw CaptureUnavailable("capture device unavailable: " + error);
      throw CaptureUnavailable(
          "timed out after " + std::to_string(timeout.count()) + " ms waiting for " +
          std::to_string(count) + " consecutive frames (had " + std::to_string(got.size()) +
          (gaps > 0 ? ", restarted after " + std::to_string(gaps) + " sequence gaps" : "") + ")" +
          (error.empty() ? "" : "; last error: " + error));
    }
    if (frame->sequence != next && !got.empty()) {
      // Lost or overwritten frames: a burst must be consecutive, start over.
      ++gaps;
      got.clear();
    }
    next = frame->sequence + 1;
    cursor.Advance(next);
    got.push_back(std::move(*frame));
  }

  Burst burst;
  SourceDescription description;
  uint64_t dropped_total = 0;
  {
    std::lock_guard<std::mutex> lock(status_mutex_);
    description = description_;
    dropped_total = status_.frames_dropped;
  }
  const bool color = !got[0].color.empty();
  burst.manifest.width = color ? got[0].color.cols : got[0].gray.cols;
  burst.manifest.height = color ? got[0].color.rows : got[0].gray.rows;
  burst.manifest.pixel_format = color ? "bgr8" : "gray8";
  burst.manifest.reference = 0;
  for (CapturedFrame& frame : got) {
    burst.manifest.frames.push_back({"", frame.timestamp_ns, frame.sequence});
    burst.frames.push_back(color ? std::move(frame.color) : std::move(frame.gray));
  }
  burst.manifest.source = {
      {"uri", config_.source},
      {"kind", description.kind},
      {"device", description.device},
      {"driver", description.driver},
      {"card", description.card},
      {"format", description.format},
      {"width", description.width},
      {"height", description.height},
      {"fps", description.fps},
      {"timestamp_clock", "CLOCK_MONOTONIC"},
      {"sequence_first", got.front().sequence},
      {"sequence_last", got.back().sequence},
      {"source_sequence_first", got.front().source_sequence},
      {"source_sequence_last", got.back().source_sequence},
      {"gaps_skipped", gaps},
      {"frames_dropped_total", dropped_total},
      {"details", description.details},
  };
  return burst;
}

}  // namespace dfsm::capture
