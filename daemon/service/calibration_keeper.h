// The daemon's camera calibration across jobs: the known calibration of the
// configuration, and the fusion of every job's own estimate (a device's
// camera stays the same burst after burst). Decides which calibration a job
// starts from, records what each job measured, and persists the fusion in
// <state_dir>/calibration/fusion.json so that a restart keeps it.
//
// Thread-safe: workers record and read it while the API reads and resets it.
//
// The header names the core types only by declaration: it is included next to
// httplib.h, and glibc's <resolv.h> (which httplib includes) defines _res as a
// macro, a name Eigen's headers use.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "daemon/service/config.h"
#include "daemon/service/job.h"

namespace dfsm {
struct CameraModel;
class CalibrationFusion;
struct KnownCalibration;
struct SparseReconstruction;
}  // namespace dfsm

namespace dfsm::service {

class CalibrationKeeper {
 public:
  // Reads calibration.file (a ConfigError names it when it cannot be used)
  // and the persisted fusion (a damaged file is moved aside and reported in
  // Snapshot()'s "notes", never fatal: the fusion restarts).
  CalibrationKeeper(const CalibrationSection& config, const std::filesystem::path& state_dir);
  ~CalibrationKeeper();

  // What a job of this size starts from, into *known: the configured file
  // (its mode), else the fused calibration once reliable (as a prior with its
  // own sigma, also self-calibrating so that the fusion gets the burst's own
  // estimate). False when the job calibrates alone (always for
  // options.calibration "self").
  bool ForJob(const JobOptions& options, int width, int height, KnownCalibration* known) const;

  // Adds the job's own estimate to the fusion, when it has one worth fusing
  // (estimated from the burst, not degenerate, with an uncertainty), and
  // stores the fusion. Returns the fusion's outcome ("fused", "outlier", ...)
  // or why the estimate was not fused. Never throws.
  std::string Record(const std::string& job, int64_t time_ms, const SparseReconstruction& sparse);

  // GET /api/v1/calibration's "fused" member.
  nlohmann::json Snapshot() const;
  // DELETE /api/v1/calibration: forget the fusion (the file stays). Throws
  // std::runtime_error when the reset cannot be stored.
  void Reset();

 private:
  void Persist() const;  // under mutex_

  const CalibrationSection config_;
  const std::filesystem::path path_;
  std::unique_ptr<CameraModel> file_camera_;  // null: no calibration.file
  std::string file_source_;
  mutable std::mutex mutex_;
  std::unique_ptr<CalibrationFusion> fusion_;
  std::vector<std::string> notes_;
};

}  // namespace dfsm::service
