#include "api/job_request.h"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/camera/rolling_shutter_options.h"
#include "core/io/bounded_json.h"
#include "daemon/service/config_keys.h"
#include "daemon/service/number_text.h"

namespace dfsm::api {
namespace {

using service::ConfigKey;
using service::ConfigKeyNamed;
using service::JobOptions;
using service::KeyType;

// A job's fields and the daemon's keys whose default, type, range and choices
// they take (config_keys.h); "calibration" has no key.
struct Field {
  const char* name;
  const char* key;
};
constexpr Field kFields[] = {{"frames", "pipeline.frames"},
                             {"when", "pipeline.when"},
                             {"planes", "pipeline.planes"},
                             {"grid", "pipeline.grid"},
                             {"init", "pipeline.init"},
                             {"rolling_shutter", "pipeline.rolling_shutter"},
                             {"dense", "pipeline.dense"},
                             {"keep_burst", "jobs.keep_burst"},
                             {"calibration", nullptr},
                             {"camera", nullptr},
                             {"max_frames", "pipeline.max_frames"}};

// A job field of choices that no daemon key stands behind.
ConfigKey ChoiceKey(const char* name, std::vector<std::string> choices) {
  ConfigKey key;
  key.name = name;
  key.type = KeyType::kString;
  key.choices = std::move(choices);
  return key;
}

const Field* FindField(const std::string& name, bool upload) {
  for (const Field& field : kFields) {
    if (name != field.name) continue;
    // "when" and "max_frames" take frames from the ring: captures only.
    if (upload ? name == "when" || name == "max_frames" : name == "camera") return nullptr;
    return &field;
  }
  return nullptr;
}

ConfigKey KeyOf(const Field& field) {
  if (field.key) return ConfigKeyNamed(field.key);
  // An upload's "camera": "capture" says the burst comes from the daemon's
  // capture camera, whose calibration it may then use and feed; "other" (the
  // default) keeps it apart. A capture's camera is the capture camera.
  if (std::string(field.name) == "camera") return ChoiceKey("camera", {"other", "capture"});
  // "auto": the configured or the fused calibration; "self": this burst alone.
  return ChoiceKey("calibration", {"auto", "self"});
}

int64_t ParseIntegerText(const std::string& field, const std::string& text) {
  const std::optional<int64_t> value = service::ParseInteger(text);
  if (!value) throw RequestError("'" + field + "' must be an integer, got '" + text + "'");
  return *value;
}

bool ParseBoolText(const std::string& field, const std::string& text) {
  if (text == "true" || text == "1") return true;
  if (text == "false" || text == "0") return false;
  throw RequestError("'" + field + "' must be true or false, got '" + text + "'");
}

// Applies one field (shared by the JSON body and the query string), already
// converted to a json value of the right kind.
void ApplyField(const std::string& name, const nlohmann::json& value, bool upload,
                const service::DaemonConfig& config, JobOptions* options) {
  const Field* field = FindField(name, upload);
  if (!field) {
    std::string known;
    for (const Field& f : kFields) {
      if (FindField(f.name, upload)) known += (known.empty() ? "" : ", ") + std::string(f.name);
    }
    throw RequestError("unknown field '" + name + "' (known: " + known + ")");
  }
  ConfigKey key = KeyOf(*field);
  const auto fail = [&](const std::string& problem) {
    throw RequestError("'" + name + "' " + problem);
  };
  const auto integer = [&]() -> int {
    if (!value.is_number_integer()) fail("must be an integer");
    const int64_t number = value.get<int64_t>();
    if (const auto problem = key.RangeProblem(number)) fail(*problem);
    return static_cast<int>(number);
  };
  const auto text = [&]() -> std::string {
    if (!value.is_string()) fail("must be a string");
    if (const auto problem = key.ChoiceProblem(value.get<std::string>())) fail(*problem);
    return value.get<std::string>();
  };
  const auto boolean = [&]() -> bool {
    if (!value.is_boolean()) fail("must be true or false");
    return value.get<bool>();
  };
  if (name == "frames") {
    // A capture takes at most the ring, or "auto": as many as its parallax
    // needs, up to max_frames; an upload at most a burst's frames (0: all).
    if (!upload && value == "auto") {
      options->auto_frames = true;
      // The ring holds no more, whatever the configured maximum.
      options->frames = std::min(config.pipeline.max_frames, config.capture.ring_frames);
      return;
    }
    if (!upload && !value.is_number_integer()) fail("must be an integer or \"auto\"");
    key.max = upload ? config.limits.max_burst_frames : config.capture.ring_frames;
    options->frames = upload && value == 0 ? 0 : integer();
  } else if (name == "max_frames") {
    if (!options->auto_frames) fail("applies to \"frames\": \"auto\" only");
    key.max = config.capture.ring_frames;
    options->frames = integer();
  } else if (name == "when") {
    options->when = service::ParseBurstWhen(text());
  } else if (name == "planes") {
    options->planes = integer();
  } else if (name == "grid") {
    options->grid = integer();
  } else if (name == "init") {
    options->init = ParseInitMode(text());
  } else if (name == "rolling_shutter") {
    options->rolling_shutter = text();
    try {
      ParseRollingShutter(options->rolling_shutter);
    } catch (const std::invalid_argument& e) {
      throw RequestError("'rolling_shutter': " + std::string(e.what()));
    }
  } else if (name == "dense") {
    options->dense = boolean();
  } else if (name == "keep_burst") {
    options->keep_burst = boolean();
  } else if (name == "calibration") {
    options->calibration = text();
  } else if (name == "camera") {
    options->camera = text();
  }
}

}  // namespace

JobOptions DefaultJobOptions(const service::DaemonConfig& config) {
  JobOptions options;
  options.frames = config.pipeline.frames;
  options.when = config.pipeline.when;
  options.planes = config.pipeline.planes;
  options.grid = config.pipeline.grid;
  options.init = config.pipeline.init;
  options.rolling_shutter = config.pipeline.rolling_shutter;
  options.dense = config.pipeline.dense;
  options.keep_burst = config.jobs.keep_burst;
  return options;
}

JobOptions ParseCaptureRequest(const std::string& body, const service::DaemonConfig& config) {
  JobOptions options = DefaultJobOptions(config);
  if (body.find_first_not_of(" \t\r\n") == std::string::npos) return options;
  nlohmann::json json;
  try {
    json = ParseBoundedJson(body);
  } catch (const JsonInputError& e) {
    throw RequestError(std::string("the body: ") + e.what());
  }
  if (!json.is_object()) throw RequestError("the body must be a JSON object");
  for (const auto& [field, value] : json.items()) {
    if (field != "max_frames") ApplyField(field, value, false, config, &options);
  }
  // After "frames", whose "auto" it qualifies.
  if (json.contains("max_frames"))
    ApplyField("max_frames", json["max_frames"], false, config, &options);
  return options;
}

JobOptions ParseUploadQuery(const std::multimap<std::string, std::string>& query,
                            const service::DaemonConfig& config) {
  JobOptions options = DefaultJobOptions(config);
  options.frames = 0;
  options.when.reset();  // an upload's frames are taken already
  options.camera = "other";
  std::string previous;
  for (const auto& [field, text] : query) {
    if (field == previous) throw RequestError("'" + field + "' is given more than once");
    previous = field;
    const Field* known = FindField(field, true);
    const KeyType type = known ? KeyOf(*known).type : KeyType::kString;
    nlohmann::json value;
    if (type == KeyType::kInt) {
      value = ParseIntegerText(field, text);
    } else if (type == KeyType::kBool) {
      value = ParseBoolText(field, text);
    } else {
      value = text;
    }
    ApplyField(field, value, true, config, &options);
  }
  return options;
}

ListQuery ParseListQuery(const std::multimap<std::string, std::string>& query) {
  ListQuery list;
  for (const auto& [field, text] : query) {
    if (field == "limit") {
      const int64_t limit = ParseIntegerText(field, text);
      if (limit < 1 || limit > 1000) {
        throw RequestError("'limit' must be in [1, 1000], got " + std::to_string(limit));
      }
      list.limit = static_cast<int>(limit);
    } else if (field == "after") {
      if (!service::IsValidJobId(text))
        throw RequestError("'after' is not a job id: '" + text + "'");
      list.after = text;
    } else if (field == "status") {
      try {
        service::ParseJobStatus(text);
      } catch (const std::invalid_argument&) {
        throw RequestError("'status' must be queued, processing, succeeded or failed, got '" +
                           text + "'");
      }
      list.status = text;
    } else {
      throw RequestError("unknown query parameter '" + field + "' (known: limit, after, status)");
    }
  }
  return list;
}

SnapshotQuery ParseSnapshotQuery(const std::multimap<std::string, std::string>& query) {
  SnapshotQuery snapshot;
  for (const auto& [field, text] : query) {
    if (field != "width")
      throw RequestError("unknown query parameter '" + field + "' (known: width)");
    const int64_t width = ParseIntegerText(field, text);
    if (width < SnapshotQuery::kMinWidth || width > SnapshotQuery::kMaxWidth)
      throw RequestError("'width' must be in [" + std::to_string(SnapshotQuery::kMinWidth) + ", " +
                         std::to_string(SnapshotQuery::kMaxWidth) + "], got " +
                         std::to_string(width));
    snapshot.width = static_cast<int>(width);
  }
  return snapshot;
}

}  // namespace dfsm::api
