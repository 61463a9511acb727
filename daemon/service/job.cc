#include "daemon/service/job.h"

#include <chrono>
#include <stdexcept>

namespace dfsm::service {

const char* JobStatusName(JobStatus status) {
  switch (status) {
    case JobStatus::kQueued:
      return "queued";
    case JobStatus::kProcessing:
      return "processing";
    case JobStatus::kSucceeded:
      return "succeeded";
    case JobStatus::kFailed:
      return "failed";
  }
  return "?";
}

JobStatus ParseJobStatus(const std::string& name) {
  for (JobStatus status :
       {JobStatus::kQueued, JobStatus::kProcessing, JobStatus::kSucceeded, JobStatus::kFailed}) {
    if (name == JobStatusName(status)) return status;
  }
  throw std::invalid_argument("unknown job status '" + name + "'");
}

double JobProgress(const Job& job) {
  if (IsFinished(job.status)) return 1.0;
  if (job.status == JobStatus::kQueued) return 0.0;
  return job.progress;
}

nlohmann::json ToJson(const Job& job) {
  nlohmann::json timings = nlohmann::json::object();
  for (const auto& [stage, ms] : job.timings_ms) timings[stage] = ms;
  nlohmann::json json = {
      {"id", job.id},
      {"origin", job.origin},
      {"status", JobStatusName(job.status)},
      {"stage", job.stage},
      {"options",
       {{"frames",
         job.options.auto_frames ? nlohmann::json("auto") : nlohmann::json(job.options.frames)},
        {"when", job.options.when ? BurstWhenName(*job.options.when) : ""},
        {"planes", job.options.planes},
        {"grid", job.options.grid},
        {"init", InitModeName(job.options.init)},
        {"rolling_shutter", job.options.rolling_shutter},
        {"dense", job.options.dense},
        {"keep_burst", job.options.keep_burst},
        {"calibration", job.options.calibration},
        {"camera", job.options.camera}}},
      {"created_ms", job.created_ms},
      {"started_ms", job.started_ms},
      {"finished_ms", job.finished_ms},
      {"attempts", job.attempts},
      {"timings_ms", timings},
      {"has_burst", job.has_burst},
      {"bytes", job.bytes},
      {"input", job.input.is_null() ? nlohmann::json::object() : job.input},
  };
  if (job.options.auto_frames) json["options"]["max_frames"] = job.options.frames;
  if (!job.error.empty()) json["error"] = job.error;
  json["warnings"] = job.warnings;
  if (!job.calibration_quality.empty()) json["calibration_quality"] = job.calibration_quality;
  return json;
}

namespace {

// Stored choice option `name` ("when", "init") parsed by `parse` (which
// throws std::invalid_argument for an unknown name); `fallback`, when not
// null, is the text of a record stored before the option existed. Whatever is
// wrong names the option and the value.
template <typename Parse>
auto ParseStoredChoice(const nlohmann::json& options, const char* name, const char* fallback,
                       Parse parse) {
  const std::string field = std::string("options.") + name;
  const auto it = options.find(name);
  if (it == options.end() && !fallback) throw std::invalid_argument(field + " is missing");
  if (it != options.end() && !it->is_string())
    throw std::invalid_argument(field + " must be a string, got " + it->dump());
  const std::string text = it == options.end() ? fallback : it->get<std::string>();
  try {
    return parse(text);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(field + ": " + e.what());  // names the value
  }
}

std::optional<BurstWhen> ParseStoredWhen(const std::string& text) {
  if (text.empty()) return std::nullopt;  // an upload's
  return ParseBurstWhen(text);
}

}  // namespace

Job JobFromJson(const nlohmann::json& json) {
  Job job;
  job.id = json.at("id").get<std::string>();
  if (!IsValidJobId(job.id)) throw std::invalid_argument("bad job id '" + job.id + "'");
  job.origin = json.value("origin", "upload");
  job.status = ParseJobStatus(json.at("status").get<std::string>());
  job.stage = json.value("stage", "");
  job.error = json.value("error", "");
  const nlohmann::json& options = json.at("options");
  if (options.at("frames") == "auto") {
    job.options.auto_frames = true;
    job.options.frames = options.at("max_frames").get<int>();
  } else {
    job.options.frames = options.at("frames").get<int>();
  }
  // Records from before the option were captures of the last frames.
  job.options.when = ParseStoredChoice(options, "when", "last", ParseStoredWhen);
  job.options.planes = options.at("planes").get<int>();
  job.options.grid = options.value("grid", 0);
  job.options.init = ParseStoredChoice(options, "init", nullptr, ParseInitMode);
  // Jobs stored before the option existed ran with a global shutter.
  job.options.rolling_shutter = options.value("rolling_shutter", "global");
  job.options.dense = options.value("dense", true);
  job.options.keep_burst = options.value("keep_burst", true);
  job.options.calibration = options.value("calibration", "auto");
  // Records from before the option: an upload's camera was not known.
  job.options.camera = options.value("camera", job.origin == "capture" ? "capture" : "other");
  job.created_ms = json.at("created_ms").get<int64_t>();
  job.started_ms = json.value("started_ms", int64_t{0});
  job.finished_ms = json.value("finished_ms", int64_t{0});
  job.attempts = json.value("attempts", 0);
  const nlohmann::json timings = json.value("timings_ms", nlohmann::json::object());
  for (const auto& [stage, ms] : timings.items()) {
    job.timings_ms.emplace_back(stage, ms.get<double>());
  }
  job.has_burst = json.value("has_burst", false);
  job.bytes = json.value("bytes", int64_t{0});
  job.input = json.value("input", nlohmann::json::object());
  job.warnings = json.value("warnings", std::vector<std::string>{});
  job.calibration_quality = json.value("calibration_quality", "");
  return job;
}

bool IsValidJobId(const std::string& id) {
  if (id.size() != 19 || id[0] != 'j' || id[14] != '-') return false;
  for (size_t i = 1; i < 14; ++i) {
    if (id[i] < '0' || id[i] > '9') return false;
  }
  for (size_t i = 15; i < 19; ++i) {
    const char c = id[i];
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace dfsm::service
