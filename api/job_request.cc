#include "api/job_request.h"

#include <nlohmann/json.hpp>
#include <optional>

#include "core/camera/rolling_shutter_options.h"
#include "core/io/bounded_json.h"
#include "daemon/service/number_text.h"

namespace dfsm::api {
namespace {

using service::JobOptions;

void CheckRange(const std::string& field, int64_t value, int64_t low, int64_t high) {
  if (value < low || value > high) {
    throw RequestError("'" + field + "' must be in [" + std::to_string(low) + ", " +
                       std::to_string(high) + "], got " + std::to_string(value));
  }
}

void CheckChoice(const std::string& field, const std::string& value, const char* a, const char* b) {
  if (value != a && value != b) {
    throw RequestError("'" + field + "' must be \"" + a + "\" or \"" + b + "\", got \"" + value +
                       "\"");
  }
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
void ApplyField(const std::string& field, const nlohmann::json& value, bool upload,
                const service::DaemonConfig& config, JobOptions* options) {
  const auto integer = [&]() -> int64_t {
    if (!value.is_number_integer()) throw RequestError("'" + field + "' must be an integer");
    return value.get<int64_t>();
  };
  const auto text = [&]() -> std::string {
    if (!value.is_string()) throw RequestError("'" + field + "' must be a string");
    return value.get<std::string>();
  };
  const auto boolean = [&]() -> bool {
    if (!value.is_boolean()) throw RequestError("'" + field + "' must be true or false");
    return value.get<bool>();
  };
  if (field == "frames") {
    const int64_t frames = integer();
    if (upload) {
      if (frames != 0) CheckRange(field, frames, 3, 1000);
    } else {
      CheckRange(field, frames, 3, config.capture.ring_frames);
    }
    options->frames = static_cast<int>(frames);
  } else if (field == "when" && !upload) {
    options->when = text();
    CheckChoice(field, options->when, "last", "next");
  } else if (field == "planes") {
    const int64_t planes = integer();
    CheckRange(field, planes, 2, 1024);
    options->planes = static_cast<int>(planes);
  } else if (field == "grid") {
    const int64_t grid = integer();
    CheckRange(field, grid, 0, 4096);
    options->grid = static_cast<int>(grid);
  } else if (field == "init") {
    options->init = text();
    CheckChoice(field, options->init, "rank1", "naive");
  } else if (field == "rolling_shutter") {
    options->rolling_shutter = text();
    try {
      ParseRollingShutter(options->rolling_shutter);
    } catch (const std::invalid_argument& e) {
      throw RequestError("'rolling_shutter': " + std::string(e.what()));
    }
  } else if (field == "dense") {
    options->dense = boolean();
  } else if (field == "keep_burst") {
    options->keep_burst = boolean();
  } else if (field == "calibration") {
    options->calibration = text();
    CheckChoice(field, options->calibration, "auto", "self");
  } else {
    throw RequestError("unknown field '" + field + "' (known: frames, " + (upload ? "" : "when, ") +
                       "planes, grid, init, rolling_shutter, dense, keep_burst, calibration)");
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
    ApplyField(field, value, false, config, &options);
  }
  return options;
}

JobOptions ParseUploadQuery(const std::multimap<std::string, std::string>& query,
                            const service::DaemonConfig& config) {
  JobOptions options = DefaultJobOptions(config);
  options.frames = 0;
  options.when.clear();
  std::string previous;
  for (const auto& [field, text] : query) {
    if (field == previous) throw RequestError("'" + field + "' is given more than once");
    previous = field;
    nlohmann::json value;
    if (field == "frames" || field == "planes" || field == "grid") {
      value = ParseIntegerText(field, text);
    } else if (field == "dense" || field == "keep_burst") {
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
      CheckRange(field, limit, 1, 1000);
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

}  // namespace dfsm::api
