// The system calls V4L2 capture makes, behind a small interface so that a
// fault-injecting fake driver can stand in for the kernel in unit tests. Every
// call behaves like the system call it wraps: -1 (or MAP_FAILED) and errno on
// failure.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <memory>
#include <string>

namespace dfsm::capture {

class V4l2Device {
 public:
  virtual ~V4l2Device() = default;
  virtual int Open(const std::string& path, int flags) = 0;
  virtual int Close(int fd) = 0;
  virtual int Ioctl(int fd, unsigned long request, void* arg) = 0;
  // poll(2) on one descriptor: the returned events (> 0), 0 on timeout, -1 on error.
  virtual int Poll(int fd, short events, int timeout_ms) = 0;
  virtual void* Mmap(size_t length, int fd, off_t offset) = 0;
  virtual int Munmap(void* address, size_t length) = 0;
};

// The real kernel interface.
std::unique_ptr<V4l2Device> MakeSystemV4l2Device();

// "YUYV" for V4L2_PIX_FMT_YUYV; four printable characters or an escaped form.
std::string FourccToString(unsigned int fourcc);
// The fourcc for "YUYV", "MJPG", ...; 0 when the string is not four characters.
unsigned int FourccFromString(const std::string& text);

}  // namespace dfsm::capture
