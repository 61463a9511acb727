// A pipeline job as the daemon tracks, stores and reports it.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/camera/rolling_shutter_options.h"
#include "core/sparse/init_mode.h"
#include "daemon/service/burst_when.h"

namespace dfsm::service {

enum class JobStatus { kQueued, kProcessing, kSucceeded, kFailed };

const char* JobStatusName(JobStatus status);
// Throws std::invalid_argument for a name that is not a status.
JobStatus ParseJobStatus(const std::string& name);
inline bool IsFinished(JobStatus status) {
  return status == JobStatus::kSucceeded || status == JobStatus::kFailed;
}

// How to process one burst: the daemon's [pipeline] defaults with the
// request's overrides applied (already validated). The enums are named in
// text only at the edges: the request (api/job_request.cc) and the record
// (ToJson / JobFromJson: "last" | "next", "rank1" | "naive").
struct JobOptions {
  int frames = 10;
  // Captures only ("frames": "auto"): `frames` is then the most the capture
  // takes, and its job keeps as many as its parallax needs
  // (core/pipeline/burst_length.h).
  bool auto_frames = false;
  // Captures only; an upload has none (stored and reported as "").
  std::optional<BurstWhen> when = BurstWhen::kLast;
  int planes = 128;
  int grid = 0;
  InitMode init = InitMode::kRankOne;
  std::string rolling_shutter = kDefaultRollingShutter;  // ParseRollingShutter's forms
  bool dense = true;
  bool keep_burst = true;
  // "auto": the configured or the fused calibration where there is one
  // (calibration_keeper.h); "self": this burst calibrates the camera alone.
  std::string calibration = "auto";
  // Which camera took the burst: "capture" (the daemon's own: every capture,
  // and an upload that says so) or "other" (an upload's default). Only the
  // capture camera's bursts use and feed its calibration
  // (calibration_keeper.h).
  std::string camera = "capture";
};

struct Job {
  std::string id;
  std::string origin;  // "capture" | "upload" | "recovered"
  JobStatus status = JobStatus::kQueued;
  // Current or last stage ("loading", "features", "sparse", "dense",
  // "writing", "done") and, while processing, how far the job has come
  // (0..1, job_progress_model.h); in memory only.
  std::string stage;
  double progress = 0.0;
  std::string error;  // when failed
  JobOptions options;
  int64_t created_ms = 0;  // Unix epoch milliseconds
  int64_t started_ms = 0;
  int64_t finished_ms = 0;
  int attempts = 0;  // times processing started (a restart mid-job adds one)
  std::vector<std::pair<std::string, double>> timings_ms;  // from result.json
  bool has_burst = false;                                  // burst still stored
  int64_t bytes = 0;                                       // on disk, when finished
  nlohmann::json input;                                    // width, height, frames of the burst
  // From result.json: what the result cannot vouch for, and the verdict on
  // its calibration ("reliable" | "uncertain" | "degenerate"; empty before).
  std::vector<std::string> warnings;
  std::string calibration_quality;
};

nlohmann::json ToJson(const Job& job);

// How far a job has come, 0..1: 0 queued, its reported progress while
// processing, 1 finished.
double JobProgress(const Job& job);
// Throws std::invalid_argument / nlohmann::json::exception for a damaged record;
// an option of unknown value (options.when, options.init) is named with it.
Job JobFromJson(const nlohmann::json& json);

// Job ids are 'j' + 13 digits of creation time in ms + '-' + 4 hex digits:
// sortable by creation, and safe as a path component.
bool IsValidJobId(const std::string& id);

int64_t NowUnixMs();

}  // namespace dfsm::service
