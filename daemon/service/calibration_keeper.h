// The daemon's camera calibration across jobs: the known calibration of the
// configuration, and per camera and image size the fusion of its jobs' own
// estimates (a device's camera stays the same burst after burst). Decides
// which calibration a job starts from, records what each job measured, and
// persists the fusions in <state_dir>/calibration/fusion.json so that a
// restart keeps them.
//
// Only the capture camera's bursts shape its calibration: captures, and
// uploads whose request says they come from it (JobOptions::camera). A fusion
// is keyed by the capture source and the image size, so a burst of another
// size never locks the camera out, and a job is counted once however often it
// runs (a crash between fusing and committing re-runs it).
//
// Thread-safe: workers record and read it while the API reads and resets it.
//
// The header names the core types only by declaration: it is included next to
// httplib.h, and glibc's <resolv.h> (which httplib includes) defines _res as a
// macro, a name Eigen's headers use.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "daemon/service/config.h"
#include "daemon/service/job.h"
#include "daemon/service/joint_calibrations.h"

namespace dfsm {
struct CameraModel;
struct OpenCvLens;
class CalibrationFusion;
struct KnownCalibration;
struct SparseReconstruction;
}  // namespace dfsm

namespace dfsm::service {

class CalibrationKeeper {
 public:
  // Reads calibration.file (a ConfigError names it when it cannot be used)
  // and the persisted fusions (a damaged file is moved aside and reported in
  // Snapshot()'s "notes", never fatal: the fusions restart). `camera` names
  // the capture camera (capture.source).
  CalibrationKeeper(const CalibrationSection& config, std::string camera,
                    const std::filesystem::path& state_dir);
  ~CalibrationKeeper();

  // What a job of this size starts from, into *known: the configured file
  // (its mode), else the camera's joint calibration at this size once
  // reliable, else its fusion once reliable (each as a prior with its own
  // sigma, also self-calibrating so that the fusion gets the burst's own
  // estimate). Both are checked against the burst (the sparse
  // stage runs twice): a fusion may hold bursts of another camera that were
  // said to be this one's. False when the job calibrates alone: always for
  // options.calibration "self" and for bursts not of the capture camera.
  bool ForJob(const JobOptions& options, int width, int height, KnownCalibration* known) const;

  // Adds the job's own estimate to its camera's fusion, when it is the
  // capture camera's, has one worth fusing (estimated from the burst, not
  // degenerate, with an uncertainty) and was not counted before; stores the
  // fusions. Returns the fusion's outcome ("fused", "outlier", ...) or why
  // the estimate was not fused. Never throws.
  std::string Record(const std::string& job, const JobOptions& options, int64_t time_ms,
                     const SparseReconstruction& sparse);

  // Remembers a job of the capture camera whose tracks file (tracks.cbor)
  // its result holds, for the joint calibration of its size. True when one
  // is due (calibration.joint_every). Never throws.
  bool RememberTracks(const std::string& job, const JobOptions& options, int width, int height);
  // The joint calibration of the size the newest remembered job had
  // (JointCalibrations::TrySolve): nullopt while another runs; throws
  // std::runtime_error where there is nothing to calibrate from.
  std::optional<nlohmann::json> SolveJoint(const JointCalibrations::TracksOf& tracks_of);

  // GET /api/v1/calibration's "fused" member: the fusion the newest job of
  // the capture camera went to (its "key" names camera and size), with
  // "other_sizes" listing the camera's other fusions.
  nlohmann::json Snapshot() const;
  // GET /api/v1/calibration's "joint" member: JointCalibrations::Snapshot of
  // the newest remembered job's size.
  nlohmann::json JointSnapshot() const;
  // DELETE /api/v1/calibration: forget every fusion and joint calibration (the file stays). Throws
  // std::runtime_error when the reset cannot be stored.
  void Reset();

 private:
  std::string Key(int width, int height) const;
  void Load();           // constructor only
  void Persist() const;  // under mutex_

  const CalibrationSection config_;
  const std::string camera_;
  const std::filesystem::path path_;
  std::unique_ptr<CameraModel> file_camera_;  // null: no calibration.file
  std::unique_ptr<OpenCvLens> file_lens_;     // the file's own lens (ImportedCalibration::lens)
  std::string file_source_;
  mutable std::mutex mutex_;
  std::map<std::string, std::unique_ptr<CalibrationFusion>> fusions_;  // by Key()
  std::string current_;  // the key the newest recorded job went to
  std::vector<std::string> notes_;
  JointCalibrations joint_;
};

// Whether a job's burst comes from the capture camera: captures always,
// uploads when their request says so (camera "capture").
bool FromCaptureCamera(const JobOptions& options);

}  // namespace dfsm::service
