// The preallocated ring of recent frames between the capture thread (the only
// writer) and any number of readers taking bursts or snapshots out of it.
//
// Invariants:
//  - The writer never waits for a reader: it fills a private staging buffer and
//    publishes it by swapping a pointer under a mutex held for O(1) work.
//  - A reader copies a frame out while holding a pin on its buffer, not the
//    mutex; a pinned buffer that falls out of the ring is not reused until it is
//    unpinned. Readers pin one buffer at a time, so at most
//    capacity + 1 + max_spares buffers ever exist (memory stays bounded); if
//    readers hold every spare, the writer gets no staging buffer and the frame
//    is dropped rather than waited for.
//  - Once the buffers are allocated (Preallocate or the first capacity + 1
//    frames) no frame of the same size allocates memory.
//  - Sequence numbers are strictly increasing; a gap means frames are missing
//    between the two neighbours.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "daemon/capture/capture_service.h"
#include "daemon/capture/frame_source.h"

namespace dfsm::capture {

class FrameRing {
 public:
  explicit FrameRing(int capacity, int max_spares = 4);
  FrameRing(const FrameRing&) = delete;
  FrameRing& operator=(const FrameRing&) = delete;

  int capacity() const { return capacity_; }

  // Allocates every buffer for frames of this size, so capture does not
  // allocate at all (called when the source has negotiated its format).
  void Preallocate(int width, int height, bool color);

  // Writer side. The buffer to fill next, or nullptr when readers pin every
  // spare buffer (the caller then drops the frame).
  FrameSlot* Staging();
  // Publishes the staging buffer as the frame `sequence` (greater than every
  // sequence published before) and wakes the waiting readers.
  void Publish(int64_t sequence);
  // Wakes the waiting readers without a frame (the service's state changed).
  void Wake();

  // Reader side.
  int Fill() const;
  std::optional<int64_t> NewestSequence() const;
  // The sequence the next Publish() evicts, or nothing while the ring is not full.
  std::optional<int64_t> NextEvicted() const;
  // The first sequence of the newest run of consecutive frames.
  std::optional<int64_t> NewestRunStart() const;

  // Copies out the oldest frame whose sequence is >= `sequence`, waiting until
  // `deadline` for it to arrive. Returns nothing on timeout or when `abort`
  // (evaluated under the ring's mutex after every wake-up) returns true. The
  // returned frame's sequence is greater than asked when that frame was lost or
  // has already been overwritten: the caller sees the gap. Only the image a
  // burst keeps is copied: colour where the frame has it (gray stays empty),
  // else gray. (At 1080p x 10 the unused gray copies were 20 MB of page
  // faults on the request thread.)
  std::optional<CapturedFrame> CopyAtOrAfter(int64_t sequence,
                                             std::chrono::steady_clock::time_point deadline,
                                             const std::function<bool()>& abort);
  // Copies out the newest frame, if any.
  std::optional<CapturedFrame> CopyNewest();

 private:
  struct Buffer {
    FrameSlot slot;
    int64_t sequence = -1;
    int pins = 0;
    bool in_ring = false;
  };

  Buffer* FindFreeLocked();
  // Which images CopyPinned copies: both, or the one a burst keeps.
  enum class Planes { kBoth, kBurst };
  std::optional<CapturedFrame> CopyPinned(Buffer* buffer, std::unique_lock<std::mutex>& lock,
                                          Planes planes);
  Buffer* AtLocked(int age) const;  // age 0: newest

  const int capacity_;
  const int max_buffers_;
  mutable std::mutex mutex_;
  std::condition_variable published_;
  std::vector<std::unique_ptr<Buffer>> buffers_;  // every buffer ever made
  std::vector<Buffer*> ring_;                     // circular, `count_` valid entries
  int head_ = 0;                                  // where the next frame goes
  int count_ = 0;
  int width_ = 0, height_ = 0;  // of the frames in the ring (Preallocate)
  bool color_ = false;
  Buffer* staging_ = nullptr;  // owned by the writer between Staging() and Publish()
};

}  // namespace dfsm::capture
