// The CaptureService implementation: one FrameSource read by a capture thread
// of its own into a FrameRing, with reopening after failures, and bursts of
// consecutive frames copied out of the ring on request.
//
// Sequence numbers are the service's own: they increase by one per frame that
// followed its predecessor without loss, and skip ahead by the number of frames
// the source reports lost (driver sequence gaps, error buffers), plus one at
// every discontinuity (a reopened device, a replay seam). A gap between two
// sequence numbers therefore always means "not consecutive in time", and
// GrabBurst never returns frames across one.
#pragma once

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include "daemon/capture/capture_service.h"
#include "daemon/capture/frame_ring.h"
#include "daemon/capture/frame_source.h"

namespace dfsm::capture {

class StreamingCaptureService : public CaptureService {
 public:
  StreamingCaptureService(CaptureConfig config, std::unique_ptr<FrameSource> source);
  ~StreamingCaptureService() override;

  void Start() override;
  void Stop() override;
  CaptureStatus Status() const override;
  Burst GrabBurst(int frames, BurstWhen when, std::chrono::milliseconds timeout) override;
  std::optional<CapturedFrame> LatestFrame() const override;

 private:
  void Run();
  bool OpenSource();
  void LoseSource(const std::string& error, bool gone);
  void SleepUnlessStopped(std::chrono::milliseconds duration);
  void ApplyHoldRequest();
  void WaitForBurstReaders();

  // Where one GrabBurst() has got to: the next sequence it needs, published
  // so that a recording can wait for it (see SourceDescription::live).
  class ReaderCursor {
   public:
    ReaderCursor(StreamingCaptureService& service, int64_t next);
    ~ReaderCursor();
    void Advance(int64_t next);

   private:
    StreamingCaptureService& service_;
    std::multiset<int64_t>::iterator position_;
  };

  const CaptureConfig config_;
  const std::unique_ptr<FrameSource> source_;
  // Logically const readers copy out of the ring; the ring has its own lock.
  mutable FrameRing ring_;

  std::thread thread_;  // touched by Start() and Stop() only
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_{false};
  std::mutex stop_mutex_;
  std::condition_variable stop_cv_;

  // Counts bursts being taken: while positive, the source holds its automatic
  // controls (applied by the capture thread, which owns the source).
  std::atomic<int> holds_{0};
  bool holding_ = false;  // capture thread only

  // The next sequence each GrabBurst() in progress needs. The capture thread
  // of a source that is not live waits rather than evict the smallest.
  std::mutex readers_mutex_;
  std::condition_variable readers_cv_;
  std::multiset<int64_t> reader_cursors_;  // guarded by readers_mutex_

  mutable std::mutex status_mutex_;
  CaptureStatus status_;           // guarded by status_mutex_
  SourceDescription description_;  // guarded by status_mutex_
  bool ever_opened_ = false;       // capture thread only
  int64_t next_sequence_ = 0;      // capture thread only
  std::atomic<bool> streaming_{false};
  std::atomic<bool> gone_{false};         // the last failure was a device that went away
  std::atomic<bool> open_failed_{false};  // the last attempt to open failed
};

}  // namespace dfsm::capture
