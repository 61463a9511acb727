#include "daemon/capture/v4l2_device.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>

namespace dfsm::capture {

namespace {

class SystemV4l2Device : public V4l2Device {
 public:
  int Open(const std::string& path, int flags) override {
    return ::open(path.c_str(), flags | O_CLOEXEC);
  }
  int Close(int fd) override { return ::close(fd); }
  int Ioctl(int fd, unsigned long request, void* arg) override {
    int result;
    // A signal may interrupt a V4L2 ioctl; the request itself is then unharmed.
    do {
      result = ::ioctl(fd, request, arg);
    } while (result == -1 && errno == EINTR);
    return result;
  }
  int Poll(int fd, short events, int timeout_ms) override {
    pollfd p{fd, events, 0};
    const int result = ::poll(&p, 1, timeout_ms);
    return result > 0 ? (p.revents == 0 ? 0 : p.revents) : result;
  }
  void* Mmap(size_t length, int fd, off_t offset) override {
    return ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, offset);
  }
  int Munmap(void* address, size_t length) override { return ::munmap(address, length); }
};

}  // namespace

std::unique_ptr<V4l2Device> MakeSystemV4l2Device() { return std::make_unique<SystemV4l2Device>(); }

std::string FourccToString(unsigned int fourcc) {
  std::string text;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((fourcc >> (8 * i)) & 0xff);
    if (c >= 0x20 && c < 0x7f) {
      text += c;
    } else {
      static const char* hex = "0123456789abcdef";
      text += "\\x";
      text += hex[(c >> 4) & 0xf];
      text += hex[c & 0xf];
    }
  }
  return text;
}

unsigned int FourccFromString(const std::string& text) {
  if (text.size() != 4) return 0;
  return static_cast<unsigned int>(static_cast<unsigned char>(text[0])) |
         static_cast<unsigned int>(static_cast<unsigned char>(text[1])) << 8 |
         static_cast<unsigned int>(static_cast<unsigned char>(text[2])) << 16 |
         static_cast<unsigned int>(static_cast<unsigned char>(text[3])) << 24;
}

}  // namespace dfsm::capture
