#include "tools/dfsm/batch_progress.h"

#include <cmath>

namespace dfsm::tools {
namespace {

constexpr int kBarWidth = 30;

std::string Duration(double seconds) {
  char text[32];
  const long s = std::lround(seconds);
  if (s >= 3600)
    std::snprintf(text, sizeof text, "%ld h %02ld min", s / 3600, s / 60 % 60);
  else if (s >= 60)
    std::snprintf(text, sizeof text, "%ld min %02ld s", s / 60, s % 60);
  else
    std::snprintf(text, sizeof text, "%ld s", s);
  return text;
}

}  // namespace

BatchProgress::BatchProgress(std::FILE* out, bool terminal, int total, int skipped)
    : out_(out), terminal_(terminal), total_(total), skipped_(skipped) {
  std::fprintf(out_, "dfsm batch: %d bursts", total_);
  if (skipped_ > 0) std::fprintf(out_, ", %d complete already (skipped)", skipped_);
  std::fprintf(out_, "\n");
  std::fflush(out_);
}

std::string BatchProgress::Line() const {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const int finished = skipped_ + done_;
  char text[160];
  std::snprintf(text, sizeof text, "%d/%d done, %d failed", finished, total_, failed_);
  std::string line = text;
  if (done_ > 0 && elapsed > 0.0) {
    const double per_second = done_ / elapsed;
    std::snprintf(text, sizeof text, ", %.1f bursts/min, %s left", 60.0 * per_second,
                  Duration((total_ - finished) / per_second).c_str());
    line += text;
  }
  return line;
}

void BatchProgress::Finished(const std::string& name, bool ok, double seconds,
                             const std::string& error) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++done_;
  if (!ok) ++failed_;
  if (terminal_) {
    if (!ok) std::fprintf(out_, "\r\033[Kfailed %s: %s\n", name.c_str(), error.c_str());
    const int finished = skipped_ + done_;
    const int filled = total_ > 0 ? kBarWidth * finished / total_ : kBarWidth;
    std::fprintf(out_, "\r\033[K[%s%s] %s", std::string(filled, '#').c_str(),
                 std::string(kBarWidth - filled, '.').c_str(), Line().c_str());
  } else {
    std::fprintf(out_, "dfsm batch: %s %s in %.1f s%s%s (%s)\n", name.c_str(), ok ? "ok" : "failed",
                 seconds, ok ? "" : ": ", ok ? "" : error.c_str(), Line().c_str());
  }
  std::fflush(out_);
}

void BatchProgress::Done(int ok, int failed) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::fprintf(
      out_, "%sdfsm batch: %d of %d bursts ok, %d failed (%d run now, %d complete before), in %s\n",
      terminal_ ? "\r\033[K" : "", ok, total_, failed, done_, skipped_, Duration(elapsed).c_str());
  std::fflush(out_);
}

}  // namespace dfsm::tools
