// An upload extracted while it is received: the HTTP thread writes the body
// into a pipe, a thread of its own extracts the tar from the other end
// (libarchive pulls, httplib pushes); the archive is never held whole.
#pragma once

#include <exception>
#include <filesystem>
#include <thread>

#include "daemon/service/tar_policy.h"

namespace dfsm::service {

class StreamingExtraction {
 public:
  // Starts extracting into `dir` (created). Throws std::system_error.
  StreamingExtraction(const std::filesystem::path& dir, const TarLimits& limits);
  // Ends the input and waits for the thread.
  ~StreamingExtraction() { End(); }
  StreamingExtraction(const StreamingExtraction&) = delete;
  StreamingExtraction& operator=(const StreamingExtraction&) = delete;

  // Passes body bytes on; blocks while the extraction is behind. After an
  // error they are read and dropped, so the body can be read to its end.
  void Write(const char* data, size_t size);
  // Ends the input, waits, and rethrows the extraction's TarError (the
  // archive) or std::system_error (the disk).
  void Finish();

 private:
  void End();

  int input_ = -1;  // the pipe's write end
  std::exception_ptr error_;
  std::thread thread_;
};

}  // namespace dfsm::service
