// How far a batch is: on a terminal one line redrawn in place (a bar, bursts
// done and failed, the rate and the time left); elsewhere (a log, a cluster's
// output file) one plain line per finished burst.
#pragma once

#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>

namespace dfsm::tools {

class BatchProgress {
 public:
  // `total` bursts, of which `skipped` were complete already (--resume).
  BatchProgress(std::FILE* out, bool terminal, int total, int skipped);

  // One burst finished: `ok` or failed, after `seconds`. Thread-safe.
  void Finished(const std::string& name, bool ok, double seconds, const std::string& error);
  // The last word: of the whole batch (skipped bursts too) `ok` and `failed`,
  // and the wall time.
  void Done(int ok, int failed);

  int failed() const { return failed_; }

 private:
  std::string Line() const;  // "12/64 done, 1 failed, 3.2 bursts/min, 4 min left"

  std::FILE* const out_;
  const bool terminal_;
  const int total_;
  const int skipped_;
  const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::mutex mutex_;
  int done_ = 0;  // this run's, failed included
  int failed_ = 0;
};

}  // namespace dfsm::tools
