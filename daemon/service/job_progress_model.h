// How far a running job is, 0..1, from the laps the pipeline reports as they
// end (core/io/progress.h) and the share of a job's time each lap takes.
// The shares are measured: they start from those of a 1080p job and follow
// this daemon's own jobs (an average over the jobs that succeeded, each
// job's laps taken as shares of its time), so that the progress a client
// sees follows time on this device and at its image size.
//
// Thread-safe.
#pragma once

#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace dfsm::service {

class JobProgressModel {
 public:
  // How much a job's measured shares move the model's (0..1).
  static constexpr double kLearningRate = 0.3;

  JobProgressModel();

  // The job's progress once `fraction` of `lap` is done: the shares of the
  // laps before it and that fraction of its own, below 1 (1 is for a
  // finished job). Null for a lap the model does not know.
  std::optional<double> Progress(const std::string& lap, double fraction) const;

  // The stage a lap belongs to, as the job list names it: "loading",
  // "features", "sparse", "dense" or "writing"; null for an unknown lap.
  static const char* StageOf(const std::string& lap);

  // Moves the shares toward those of a job that succeeded: its laps with
  // their milliseconds, in any order; a lap it did not run counts as 0 ms.
  void Learn(const std::vector<std::pair<std::string, double>>& laps_ms);

 private:
  mutable std::mutex mutex_;
  std::vector<double> shares_;  // per lap of kLaps (job_progress_model.cc), summing to 1
};

}  // namespace dfsm::service
