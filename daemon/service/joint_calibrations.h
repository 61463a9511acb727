// The capture camera's joint calibrations (core/sparse/joint_adjustment.h),
// one per image size: which jobs' tracks each is made of (the newest
// `bursts` of the capture camera at that size, each job's tracks.cbor), when
// the next is due (every `every` new jobs; 0: only on request), and the
// newest result. Persisted in <state_dir>/calibration/joint.json; a damaged
// file is moved aside (joint.json.damaged) and noted, never fatal.
//
// Thread-safe; a solve reads and adjusts without the lock (seconds), and one
// solve runs at a time (TrySolve says when another is running).
//
// Declares the core types only (see calibration_keeper.h: httplib.h's macros).
#pragma once

#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace dfsm::service {

// A job's tracks for the joint calibration, beside its result
// (core/sparse/joint_burst_file.h; not served by the API).
inline constexpr const char* kTracksFile = "tracks.cbor";

class JointCalibrations {
 public:
  // Where a job's tracks file is (JobStore::OutputDir / "tracks.cbor").
  using TracksOf = std::function<std::filesystem::path(const std::string& job)>;

  JointCalibrations(const std::filesystem::path& state_dir, int bursts, int every);

  // Remembers `job` as the newest of its size `key` (at most `bursts` kept).
  // True when `every` jobs of that size came since its last solve: one is
  // due. Stores the list; never throws (a full disk: noted in memory).
  bool Remember(const std::string& key, const std::string& job);

  // The key of the newest remembered job ("" before the first).
  std::string current() const;

  // Adjusts the remembered jobs of `key` jointly, their tracks read through
  // `tracks_of` (a job whose file is gone or damaged is listed with why and
  // left out), stores and returns the result (Snapshot's form). Nullopt when
  // another solve is running. Throws std::runtime_error when no job's
  // tracks can be read.
  std::optional<nlohmann::json> TrySolve(const std::string& key, const TracksOf& tracks_of);

  // The newest result of `key` when its verdict is reliable: the joint
  // calibration's JSON (ToJson(JointCalibration, ...)) with "solved_ms"; a
  // burst's "name" is its job.
  std::optional<nlohmann::json> Reliable(const std::string& key) const;

  // {"key", "jobs" (remembered), "due_in" (jobs until the next solve; null
  // when only on request), "result" (null before the first solve)}.
  nlohmann::json Snapshot(const std::string& key) const;

  // Forgets every result and list (DELETE /api/v1/calibration).
  void Reset();

  std::vector<std::string> notes() const;

 private:
  struct Entry {
    std::deque<std::string> jobs;  // oldest first
    int since_solve = 0;
    nlohmann::json result;  // null: never solved
  };
  void Persist() const;  // under mutex_; throws std::runtime_error

  const std::filesystem::path path_;
  const int bursts_, every_;
  mutable std::mutex mutex_;
  std::mutex solving_;
  std::map<std::string, Entry> entries_;
  std::string current_;
  std::vector<std::string> notes_;
};

}  // namespace dfsm::service
