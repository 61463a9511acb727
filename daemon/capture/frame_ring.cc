#include "daemon/capture/frame_ring.h"

#include <algorithm>
#include <stdexcept>

namespace dfsm::capture {

FrameRing::FrameRing(int capacity, int max_spares)
    : capacity_(capacity), max_buffers_(capacity + 1 + std::max(0, max_spares)) {
  if (capacity < 1) throw std::invalid_argument("FrameRing: capacity must be at least 1");
  ring_.assign(static_cast<size_t>(capacity), nullptr);
  buffers_.reserve(static_cast<size_t>(max_buffers_));
}

void FrameRing::Preallocate(int width, int height, bool color) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Frames of another size cannot join a burst with the new ones: forget them
  // rather than hand out buffers whose contents the reallocation discarded.
  if (width != width_ || height != height_ || color != color_) {
    for (auto& entry : ring_) {
      if (entry != nullptr) entry->in_ring = false;
      entry = nullptr;
    }
    count_ = 0;
    head_ = 0;
    width_ = width;
    height_ = height;
    color_ = color;
  }
  // The ring plus one staging buffer; spares appear only under reader pressure.
  while (static_cast<int>(buffers_.size()) < capacity_ + 1)
    buffers_.push_back(std::make_unique<Buffer>());
  for (auto& buffer : buffers_) {
    if (buffer->pins > 0 || buffer->in_ring) continue;  // being copied, or a valid frame
    // Touch every page now, so capture does not pay the page faults frame by
    // frame while the first pass through the ring fills it.
    if (buffer->slot.gray.rows != height || buffer->slot.gray.cols != width) {
      buffer->slot.gray.create(height, width, CV_8UC1);
      buffer->slot.gray.setTo(0);
    }
    if (!color) {
      buffer->slot.color.release();
    } else if (buffer->slot.color.rows != height || buffer->slot.color.cols != width) {
      buffer->slot.color.create(height, width, CV_8UC3);
      buffer->slot.color.setTo(0);
    }
  }
}

FrameRing::Buffer* FrameRing::FindFreeLocked() {
  for (auto& buffer : buffers_)
    if (!buffer->in_ring && buffer->pins == 0 && buffer.get() != staging_) return buffer.get();
  if (static_cast<int>(buffers_.size()) < max_buffers_) {
    // A spare, needed only while readers pin buffers: give it the ring's size
    // now, so the source does not allocate in the capture path.
    buffers_.push_back(std::make_unique<Buffer>());
    Buffer* spare = buffers_.back().get();
    if (width_ > 0) {
      spare->slot.gray.create(height_, width_, CV_8UC1);
      if (color_) spare->slot.color.create(height_, width_, CV_8UC3);
    }
    return spare;
  }
  return nullptr;
}

FrameSlot* FrameRing::Staging() {
  if (staging_ == nullptr) {
    std::lock_guard<std::mutex> lock(mutex_);
    staging_ = FindFreeLocked();
  }
  return staging_ == nullptr ? nullptr : &staging_->slot;
}

void FrameRing::Publish(int64_t sequence) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (staging_ == nullptr) throw std::logic_error("FrameRing::Publish without a staging buffer");
    Buffer* evicted = ring_[static_cast<size_t>(head_)];
    if (evicted != nullptr) evicted->in_ring = false;
    staging_->sequence = sequence;
    staging_->in_ring = true;
    ring_[static_cast<size_t>(head_)] = staging_;
    head_ = (head_ + 1) % capacity_;
    count_ = std::min(count_ + 1, capacity_);
    // The evicted buffer is the natural next staging buffer (no search) unless
    // a reader is still copying out of it.
    staging_ = (evicted != nullptr && evicted->pins == 0) ? evicted : FindFreeLocked();
  }
  published_.notify_all();
}

void FrameRing::Wake() {
  { std::lock_guard<std::mutex> lock(mutex_); }
  published_.notify_all();
}

FrameRing::Buffer* FrameRing::AtLocked(int age) const {
  if (age < 0 || age >= count_) return nullptr;
  const int index = ((head_ - 1 - age) % capacity_ + capacity_) % capacity_;
  return ring_[static_cast<size_t>(index)];
}

int FrameRing::Fill() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return count_;
}

std::optional<int64_t> FrameRing::NewestSequence() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (count_ == 0) return std::nullopt;
  return AtLocked(0)->sequence;
}

std::optional<int64_t> FrameRing::NextEvicted() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (count_ < capacity_) return std::nullopt;
  return AtLocked(count_ - 1)->sequence;
}

std::optional<int64_t> FrameRing::NewestRunStart() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (count_ == 0) return std::nullopt;
  int64_t start = AtLocked(0)->sequence;
  for (int age = 1; age < count_; ++age) {
    const int64_t sequence = AtLocked(age)->sequence;
    if (sequence != start - 1) break;
    start = sequence;
  }
  return start;
}

std::optional<CapturedFrame> FrameRing::CopyPinned(Buffer* buffer,
                                                   std::unique_lock<std::mutex>& lock,
                                                   Planes planes) {
  ++buffer->pins;
  const int64_t sequence = buffer->sequence;
  lock.unlock();
  // The writer never touches a pinned buffer, so the copy needs no lock.
  CapturedFrame frame;
  frame.sequence = sequence;
  frame.timestamp_ns = buffer->slot.timestamp_ns;
  frame.source_sequence = buffer->slot.source_sequence;
  const bool color = !buffer->slot.color.empty();
  if (color) frame.color = buffer->slot.color.clone();
  if (!color || planes == Planes::kBoth) frame.gray = buffer->slot.gray.clone();
  lock.lock();
  --buffer->pins;
  return frame;
}

std::optional<CapturedFrame> FrameRing::CopyAtOrAfter(
    int64_t sequence, std::chrono::steady_clock::time_point deadline,
    const std::function<bool()>& abort) {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    if (abort && abort()) return std::nullopt;
    // Entries are in increasing sequence order from oldest to newest.
    for (int age = count_ - 1; age >= 0; --age) {
      Buffer* buffer = AtLocked(age);
      if (buffer->sequence >= sequence) return CopyPinned(buffer, lock, Planes::kBurst);
    }
    if (published_.wait_until(lock, deadline) == std::cv_status::timeout) {
      // One last look: the frame may have arrived together with the deadline.
      for (int age = count_ - 1; age >= 0; --age) {
        Buffer* buffer = AtLocked(age);
        if (buffer->sequence >= sequence) return CopyPinned(buffer, lock, Planes::kBurst);
      }
      return std::nullopt;
    }
  }
}

std::optional<CapturedFrame> FrameRing::CopyNewest() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (count_ == 0) return std::nullopt;
  return CopyPinned(AtLocked(0), lock, Planes::kBoth);
}

}  // namespace dfsm::capture
