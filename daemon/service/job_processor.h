// Runs one stored job through the pipeline: status transitions, outputs
// written beside the job, metrics, retention. Called by the scheduler's workers.
//
// Invariant: whatever happens (bad burst, pipeline failure, I/O error), the job
// ends succeeded or failed with a reason, and output/ appears whole or not at all.
#pragma once

#include <memory>
#include <string>

#include "core/io/burst.h"
#include "core/pipeline/burst_length.h"
#include "daemon/service/burst_persister.h"
#include "daemon/service/calibration_keeper.h"
#include "daemon/service/config.h"
#include "daemon/service/job_progress_model.h"
#include "daemon/service/job_store.h"
#include "daemon/service/metrics.h"

namespace dfsm {
struct PipelineOutput;
}  // namespace dfsm

namespace dfsm::service {

class JobProcessor {
 public:
  // A job interrupted this many times (a crash or kill mid-run each time) is
  // failed instead of run again: it may be what kills the daemon.
  static constexpr int kMaxAttempts = 3;

  // `calibration` may be null: every job then calibrates alone. `persister`
  // may be null where no job is a capture stored in the background.
  // `burst_length`: how a capture of "frames": "auto" keeps its frames.
  JobProcessor(JobStore* store, Metrics* metrics, RetentionSection retention,
               CalibrationKeeper* calibration = nullptr, BurstPersister* persister = nullptr,
               BurstLengthOptions burst_length = {})
      : store_(store),
        metrics_(metrics),
        retention_(retention),
        calibration_(calibration),
        persister_(persister),
        burst_length_(std::move(burst_length)) {}

  // Never throws.
  void Process(const std::string& id, std::shared_ptr<const Burst> preloaded);

 private:
  void Finish(Job* job, bool ok, const std::string& error);
  // Teaches progress_ the laps of a job that succeeded.
  // Remembers a successful job's tracks for the camera's joint calibration,
  // and makes one where it is due (CalibrationKeeper::RememberTracks).
  void JoinCalibration(const Job& job, int width, int height);
  void LearnShares(double loading_ms, const PipelineOutput& output, double writing_ms);

  JobStore* store_;
  Metrics* metrics_;
  const RetentionSection retention_;
  CalibrationKeeper* calibration_;
  BurstPersister* persister_;
  const BurstLengthOptions burst_length_;
  JobProgressModel progress_;
};

}  // namespace dfsm::service
