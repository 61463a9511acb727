// A V4L2 driver in memory, for the error paths a real driver cannot produce on
// demand: EAGAIN after poll, buffers flagged with errors, EIO, an unplug and
// return, timeouts, sequence gaps, padded rows, a format changed mid-stream.
// Test-only (library dfsm_capture_fake); the happy paths are tested against
// the kernel's vivid driver in tests/vm.
//
// Frames carry a pattern the tests can check: luma(x, y) = (x + 2y + 3s) & 0xff
// for driver sequence s, chroma 128.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <vector>

#include "daemon/capture/v4l2_device.h"

namespace dfsm::capture {

enum class FakeFault {
  kEagain,        // poll says readable, DQBUF answers EAGAIN
  kErrorFlag,     // the next buffer comes back with V4L2_BUF_FLAG_ERROR
  kEio,           // DQBUF answers EIO until the stream is restarted
  kFatalAfter,    // a buffer is delivered, then the queue fails: QBUF answers EIO
  kUnplug,        // the device disappears (ENODEV); see unplugged_open_failures
  kTimeout,       // poll times out once
  kSkip2,         // the driver loses two frames (sequence jumps by 3)
  kFormatChange,  // the driver silently switches to 320x240
  kSourceChange,  // the driver switches to 320x240 and raises a source-change event
};

struct FakeV4l2Driver {
  std::mutex mutex;
  // What the driver offers.
  std::vector<uint32_t> formats;  // default YUYV, NV12, GREY
  int max_width = 640, max_height = 480;
  int row_padding = 0;  // bytes added to every row (odd bytesperline)
  uint32_t max_buffers = 8;
  bool has_timeperframe = true;
  double max_fps = 30.0;
  // Faults, consumed one per poll/DQBUF round in order.
  std::deque<FakeFault> faults;
  int unplugged_open_failures = 2;  // opens that fail with ENOENT after an unplug

  // Driver state (read by tests).
  bool present = true;
  bool streaming = false;
  bool error_state = false;
  uint32_t fourcc = 0;
  int width = 0, height = 0, bytesperline = 0;
  uint32_t sizeimage = 0;
  double fps = 30.0;
  uint32_t sequence = 0;
  int open_fds = 0;
  int opens = 0, streamons = 0, mapped = 0;
  int outstanding = 0, max_outstanding = 0;  // dequeued and not yet queued again
  bool event_pending = false;

  FakeV4l2Driver();
};

// The device interface over a shared FakeV4l2Driver (the test keeps a handle).
std::unique_ptr<V4l2Device> MakeFakeV4l2Device(std::shared_ptr<FakeV4l2Driver> driver);

}  // namespace dfsm::capture
