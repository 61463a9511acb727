#include "daemon/service/streaming_extraction.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>
#include <utility>
#include <vector>

#include "daemon/service/tar_extract.h"

namespace dfsm::service {
StreamingExtraction::StreamingExtraction(const std::filesystem::path& dir,
                                         const TarLimits& limits) {
  std::filesystem::create_directories(dir);
  int ends[2];
  if (::pipe2(ends, O_CLOEXEC) != 0)
    throw std::system_error(errno, std::generic_category(), "cannot make a pipe for the upload");
  auto run = [this, output = ends[0], dir, limits] {
    try {
      const auto read = [output](char* buffer, size_t size) {
        ssize_t n;
        while ((n = ::read(output, buffer, size)) < 0 && errno == EINTR) {
        }
        if (n < 0) throw std::system_error(errno, std::generic_category(), "upload pipe");
        return static_cast<size_t>(n);
      };
      ExtractTar(read, dir, limits);
    } catch (...) {
      error_ = std::current_exception();
    }
    // Whatever follows the archive or an error is dropped until the writer
    // closes its end: Write never waits on a reader that has gone.
    std::vector<char> sink(64 << 10);
    ssize_t n;
    do n = ::read(output, sink.data(), sink.size());
    while (n > 0 || (n < 0 && errno == EINTR));
    ::close(output);
  };
  try {
    thread_ = std::thread(std::move(run));
  } catch (...) {  // no thread: both ends are still ours
    ::close(ends[0]);
    ::close(ends[1]);
    throw;
  }
  input_ = ends[1];
}

void StreamingExtraction::Write(const char* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(input_, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      throw std::system_error(errno, std::generic_category(), "cannot pass the upload on");
    data += n;
    size -= static_cast<size_t>(n);
  }
}

void StreamingExtraction::Finish() {
  End();
  if (error_) std::rethrow_exception(error_);
}

void StreamingExtraction::End() {
  if (input_ >= 0) ::close(input_);
  input_ = -1;
  if (thread_.joinable()) thread_.join();
}

}  // namespace dfsm::service
