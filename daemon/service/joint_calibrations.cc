#include "daemon/service/joint_calibrations.h"

#include <stdexcept>

#include "core/io/bounded_json.h"
#include "core/io/file_util.h"
#include "core/sparse/joint_adjustment.h"
#include "core/sparse/joint_burst_file.h"
#include "daemon/service/job.h"

namespace dfsm::service {
namespace fs = std::filesystem;
namespace {

constexpr const char* kJointFormat = "dfsm-joint-calibrations/1";

// `what` with the file's path replaced by the job's name for it.
std::string Reworded(std::string what, const fs::path& file, const std::string& job) {
  const std::string path = file.string();
  for (size_t at = what.find(path); at != std::string::npos; at = what.find(path))
    what.replace(at, path.size(), "job " + job + "'s tracks");
  return what;
}

nlohmann::json ResultJson(const JointCalibration& joint, const std::vector<JointBurst>& bursts,
                          nlohmann::json unreadable) {
  nlohmann::json result = ToJson(joint, bursts);
  for (nlohmann::json& entry : unreadable) result["bursts"].push_back(std::move(entry));
  result["solved_ms"] = NowUnixMs();
  return result;
}

}  // namespace

JointCalibrations::JointCalibrations(const fs::path& state_dir, int bursts, int every)
    : path_(state_dir / "calibration" / "joint.json"), bursts_(bursts), every_(every) {
  std::error_code error;
  if (!fs::exists(path_, error)) return;
  try {
    const nlohmann::json stored = ParseBoundedJson(ReadFileToString(path_));
    if (stored.value("format", "") != kJointFormat)
      throw std::runtime_error(std::string("not of format ") + kJointFormat);
    for (const auto& [key, value] : stored.at("entries").items()) {
      Entry entry;
      for (const auto& job : value.at("jobs")) entry.jobs.push_back(job.get<std::string>());
      entry.since_solve = value.at("since_solve").get<int>();
      entry.result = value.at("result");
      entries_[key] = std::move(entry);
    }
    current_ = stored.value("current", "");
  } catch (const std::exception& e) {
    const fs::path aside = path_.string() + ".damaged";
    fs::rename(path_, aside, error);
    notes_.push_back("the stored joint calibrations were unreadable (" + std::string(e.what()) +
                     "); moved to " + aside.filename().string());
    entries_.clear();
  }
}

bool JointCalibrations::Remember(const std::string& key, const std::string& job) {
  std::lock_guard<std::mutex> lock(mutex_);
  current_ = key;
  Entry& entry = entries_[key];
  for (const std::string& known : entry.jobs)
    if (known == job) return false;  // a job re-run after a crash counts once
  entry.jobs.push_back(job);
  while (static_cast<int>(entry.jobs.size()) > bursts_) entry.jobs.pop_front();
  ++entry.since_solve;
  try {
    Persist();
  } catch (const std::exception& e) {
    notes_.push_back(std::string("the joint calibrations' jobs were not stored: ") + e.what());
  }
  return every_ > 0 && entry.since_solve >= every_;
}

std::optional<nlohmann::json> JointCalibrations::TrySolve(const std::string& key,
                                                          const TracksOf& tracks_of) {
  std::unique_lock<std::mutex> solving(solving_, std::try_to_lock);
  if (!solving.owns_lock()) return std::nullopt;
  std::deque<std::string> jobs;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto found = entries_.find(key);
    if (found != entries_.end()) jobs = found->second.jobs;
  }
  std::vector<JointBurst> bursts;
  nlohmann::json unreadable = nlohmann::json::array();
  for (const std::string& job : jobs) {
    const fs::path file = tracks_of(job);
    try {
      bursts.push_back(ReadJointBurst(file));
      bursts.back().name = job;
    } catch (const std::exception& e) {
      unreadable.push_back(
          {{"name", job}, {"outcome", "unreadable"}, {"reason", Reworded(e.what(), file, job)}});
    }
  }
  if (bursts.empty())
    throw std::runtime_error("no job of " + key + " has tracks to calibrate from (" +
                             std::to_string(jobs.size()) + " remembered)");
  const SparseOptions sparse;  // the pipeline's defaults: the readout estimated
  const JointCalibration joint = AdjustJointly(bursts, JointOptionsFor(sparse));
  nlohmann::json result = ResultJson(joint, bursts, std::move(unreadable));
  std::lock_guard<std::mutex> lock(mutex_);
  Entry& entry = entries_[key];
  entry.result = result;
  entry.since_solve = 0;
  try {
    Persist();
  } catch (const std::exception& e) {
    notes_.push_back(std::string("the joint calibration was not stored: ") + e.what());
  }
  return result;
}

std::optional<nlohmann::json> JointCalibrations::Reliable(const std::string& key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = entries_.find(key);
  if (found == entries_.end() || found->second.result.is_null()) return std::nullopt;
  const nlohmann::json& result = found->second.result;
  if (result.at("verdict").value("quality", "") != "reliable") return std::nullopt;
  // A result stored in an older form (no nested uncertainty) waits for the
  // next solve.
  if (!result.contains("uncertainty") || !result["uncertainty"].is_object()) return std::nullopt;
  return result;
}

nlohmann::json JointCalibrations::Snapshot(const std::string& key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = entries_.find(key);
  nlohmann::json snapshot = {{"key", key}, {"jobs", nlohmann::json::array()}, {"result", nullptr}};
  snapshot["due_in"] = every_ > 0 ? nlohmann::json(every_) : nlohmann::json(nullptr);
  if (found == entries_.end()) return snapshot;
  snapshot["jobs"] = found->second.jobs;
  snapshot["result"] = found->second.result;
  if (every_ > 0) snapshot["due_in"] = std::max(0, every_ - found->second.since_solve);
  return snapshot;
}

std::string JointCalibrations::current() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return current_;
}

void JointCalibrations::Reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.clear();
  Persist();
}

std::vector<std::string> JointCalibrations::notes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return notes_;
}

void JointCalibrations::Persist() const {
  nlohmann::json stored = {
      {"format", kJointFormat}, {"current", current_}, {"entries", nlohmann::json::object()}};
  for (const auto& [key, entry] : entries_)
    stored["entries"][key] = {
        {"jobs", entry.jobs}, {"since_solve", entry.since_solve}, {"result", entry.result}};
  fs::create_directories(path_.parent_path());
  WriteFileAtomically(path_, stored.dump(2) + "\n");
}

}  // namespace dfsm::service
