#include "daemon/log/log.h"

#include <errno.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <mutex>
#include <string>

namespace dfsm::log {
namespace {

std::mutex& Mutex() {
  static std::mutex mutex;
  return mutex;
}

void WriteLocked(Priority priority, std::string_view message) {
  static const bool journal = std::getenv("JOURNAL_STREAM") != nullptr;
  std::string line;
  if (journal) line = "<" + std::to_string(static_cast<int>(priority)) + ">";
  line += program_invocation_short_name;
  line += ": ";
  line += message;
  line += '\n';
  // One write(2): a line is never split between threads or processes.
  for (size_t done = 0; done < line.size();) {
    const ssize_t n = ::write(STDERR_FILENO, line.data() + done, line.size() - done);
    if (n <= 0 && errno != EINTR) return;
    if (n > 0) done += static_cast<size_t>(n);
  }
}

}  // namespace

void Write(Priority priority, std::string_view message) {
  std::lock_guard<std::mutex> lock(Mutex());
  WriteLocked(priority, message);
}

bool WriteLimited(Priority priority, std::string_view key, std::string_view message,
                  int per_minute) {
  struct Window {
    std::chrono::steady_clock::time_point start;
    int written = 0;
    int suppressed = 0;
  };
  static std::map<std::string, Window, std::less<>> windows;
  std::lock_guard<std::mutex> lock(Mutex());
  const auto now = std::chrono::steady_clock::now();
  auto found = windows.find(key);
  if (found == windows.end()) found = windows.emplace(std::string(key), Window{now}).first;
  Window& window = found->second;
  if (now - window.start >= std::chrono::minutes(1)) {
    if (window.suppressed > 0) {
      WriteLocked(priority, std::to_string(window.suppressed) + " more '" + std::string(key) +
                                "' lines were left out in the last minute");
    }
    window = Window{now};
  }
  if (window.written >= per_minute) {
    ++window.suppressed;
    return false;
  }
  ++window.written;
  WriteLocked(priority, message);
  return true;
}

}  // namespace dfsm::log
