#include "daemon/service/config.h"

#include <toml++/toml.h>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>

#include "core/camera/rolling_shutter_options.h"
#include "daemon/service/access_token.h"
#include "daemon/service/number_text.h"

namespace dfsm::service {
namespace {

enum class KeyType { kString, kInt, kInt64, kDouble, kBool, kPath };

// One configurable key. `field` returns the member it sets, so the TOML reader,
// the flag parser and --help share this single table.
struct Key {
  const char* name;  // "section.key"
  KeyType type;
  const char* help;
  std::function<void*(DaemonConfig*)> field;
};

#define DFSM_KEY(name, type, member, help)                                \
  Key {                                                                   \
    name, type, help, [](DaemonConfig* c) -> void* { return &c->member; } \
  }

const std::vector<Key>& Keys() {
  static const std::vector<Key> keys = {
      DFSM_KEY("server.listen", KeyType::kString, server.listen, "address to bind"),
      DFSM_KEY("server.port", KeyType::kInt, server.port, "TCP port (0: any free port)"),
      DFSM_KEY("server.threads", KeyType::kInt, server.threads,
               "HTTP workers for uploads, captures and downloads"),
      DFSM_KEY("server.control_threads", KeyType::kInt, server.control_threads,
               "HTTP workers for probes, status and lists"),
      DFSM_KEY("server.max_body_bytes", KeyType::kInt64, server.max_body_bytes,
               "largest request body (uploads), bytes"),
      DFSM_KEY("server.max_connections", KeyType::kInt, server.max_connections,
               "connections open at once (the oldest waiting one is closed for a new one)"),
      DFSM_KEY("server.head_timeout_ms", KeyType::kInt, server.head_timeout_ms,
               "time for a request's line and headers to arrive (else 408)"),
      DFSM_KEY("server.max_head_bytes", KeyType::kInt, server.max_head_bytes,
               "largest request line and headers, bytes (else 431)"),
      DFSM_KEY("server.event_stream_s", KeyType::kInt, server.event_stream_s,
               "seconds a GET /api/v1/events stream lasts before the client reconnects"),
      DFSM_KEY("server.allowed_hosts", KeyType::kString, server.allowed_hosts,
               "Host names accepted, comma-separated (empty: localhost, host name, listen; "
               "IP addresses always; *: any)"),
      DFSM_KEY("server.cors_origin", KeyType::kString, server.cors_origin,
               "Access-Control-Allow-Origin value; empty: CORS off"),
      DFSM_KEY("server.token_file", KeyType::kPath, server.token_file,
               "bearer token file (required unless listen is loopback)"),
      DFSM_KEY("server.token_credential", KeyType::kString, server.token_credential,
               "systemd credential holding the token when token_file is unset"),
      DFSM_KEY("capture.source", KeyType::kString, capture.source,
               "v4l2:/dev/videoN | libcamera:<id> | replay:<burst dir> | synthetic:"),
      DFSM_KEY("capture.width", KeyType::kInt, capture.width, "requested width (0: driver's)"),
      DFSM_KEY("capture.height", KeyType::kInt, capture.height, "requested height (0: driver's)"),
      DFSM_KEY("capture.fps", KeyType::kDouble, capture.fps, "requested frame rate (0: default)"),
      DFSM_KEY("capture.pixel_format", KeyType::kString, capture.pixel_format,
               "V4L2 fourcc preference, e.g. YUYV; empty: automatic"),
      DFSM_KEY("capture.ring_frames", KeyType::kInt, capture.ring_frames, "ring buffer, frames"),
      DFSM_KEY("capture.device_buffers", KeyType::kInt, capture.device_buffers,
               "driver buffers / requests in flight (>= 4)"),
      DFSM_KEY("capture.frame_timeout_ms", KeyType::kInt, capture.frame_timeout_ms,
               "no frame for this long: reopen the device"),
      DFSM_KEY("capture.reconnect_backoff_ms", KeyType::kInt, capture.reconnect_backoff_ms,
               "wait between reopen attempts"),
      DFSM_KEY("capture.stall_timeout_ms", KeyType::kInt, capture.stall_timeout_ms,
               "no frame for this long: stop watchdog pings (0: never)"),
      DFSM_KEY("pipeline.frames", KeyType::kInt, pipeline.frames, "frames per burst"),
      DFSM_KEY("pipeline.when", KeyType::kString, pipeline.when,
               "last: frames already in the ring | next: frames still to come"),
      DFSM_KEY("pipeline.planes", KeyType::kInt, pipeline.planes, "plane-sweep depth planes"),
      DFSM_KEY("pipeline.grid", KeyType::kInt, pipeline.grid,
               "feature grid cell, pixels (0: scaled with the image)"),
      DFSM_KEY("pipeline.init", KeyType::kString, pipeline.init, "rank1 | naive"),
      DFSM_KEY("pipeline.rolling_shutter", KeyType::kString, pipeline.rolling_shutter,
               "global | estimate | readout in [0, 1] of the frame interval"),
      DFSM_KEY("pipeline.dense", KeyType::kBool, pipeline.dense, "compute the dense depth map"),
      DFSM_KEY("pipeline.burst_timeout_ms", KeyType::kInt, pipeline.burst_timeout_ms,
               "longest wait for a 'next' burst"),
      DFSM_KEY("calibration.file", KeyType::kPath, calibration.file,
               "known calibration for every job (calibration.json/.yaml, OpenCV, ROS); empty: "
               "none"),
      DFSM_KEY("calibration.mode", KeyType::kString, calibration.mode,
               "prior | fixed: how calibration.file enters the adjustment"),
      DFSM_KEY("calibration.fuse", KeyType::kBool, calibration.fuse,
               "fuse every job's calibration (GET/DELETE /api/v1/calibration)"),
      DFSM_KEY("calibration.use_fused", KeyType::kString, calibration.use_fused,
               "prior: jobs use the fused calibration once reliable | off"),
      DFSM_KEY("jobs.state_dir", KeyType::kPath, jobs.state_dir,
               "jobs, bursts and results (default $STATE_DIRECTORY or /var/lib/dfsmd)"),
      DFSM_KEY("jobs.workers", KeyType::kInt, jobs.workers, "pipeline jobs run at once"),
      DFSM_KEY("jobs.queue", KeyType::kInt, jobs.queue, "jobs waiting at most; more: 503"),
      DFSM_KEY("jobs.keep_burst", KeyType::kBool, jobs.keep_burst,
               "keep each job's burst after success (default of the request field)"),
      DFSM_KEY("jobs.retry_after_s", KeyType::kInt, jobs.retry_after_s,
               "Retry-After of a 503 when the queue is full"),
      DFSM_KEY("retention.max_jobs", KeyType::kInt, retention.max_jobs,
               "finished jobs kept at most (0: no limit)"),
      DFSM_KEY("retention.max_bytes", KeyType::kInt64, retention.max_bytes,
               "bytes of finished jobs kept at most (0: no limit)"),
      DFSM_KEY("retention.max_age_s", KeyType::kInt64, retention.max_age_s,
               "finished jobs older than this are removed (0: never)"),
      DFSM_KEY("limits.max_upload_entries", KeyType::kInt, limits.max_upload_entries,
               "files and directories in one uploaded tar"),
      DFSM_KEY("limits.max_upload_file_bytes", KeyType::kInt64, limits.max_upload_file_bytes,
               "largest file in an uploaded tar, bytes"),
      DFSM_KEY("limits.max_burst_frames", KeyType::kInt, limits.max_burst_frames,
               "frames in an uploaded burst's manifest"),
      DFSM_KEY("limits.max_frame_pixels", KeyType::kInt64, limits.max_frame_pixels,
               "width x height of one uploaded frame"),
      DFSM_KEY("limits.max_burst_pixels", KeyType::kInt64, limits.max_burst_pixels,
               "width x height x frames decoded for one uploaded burst"),
  };
  return keys;
}
#undef DFSM_KEY

const Key* FindKey(const std::string& name) {
  for (const Key& key : Keys()) {
    if (name == key.name) return &key;
  }
  return nullptr;
}

const char* TypeName(KeyType type) {
  switch (type) {
    case KeyType::kString:
    case KeyType::kPath:
      return "string";
    case KeyType::kInt:
    case KeyType::kInt64:
      return "integer";
    case KeyType::kDouble:
      return "number";
    case KeyType::kBool:
      return "boolean";
  }
  return "?";
}

std::string WithArticle(KeyType type) {
  return (type == KeyType::kInt || type == KeyType::kInt64 ? "an " : "a ") +
         std::string(TypeName(type));
}

ConfigError KeyError(const std::string& key, const std::string& problem) {
  return ConfigError(key + ": " + problem);
}

void SetInteger(const Key& key, int64_t value, DaemonConfig* config) {
  void* field = key.field(config);
  if (key.type == KeyType::kInt64) {
    *static_cast<int64_t*>(field) = value;
  } else if (value < std::numeric_limits<int>::min() || value > std::numeric_limits<int>::max()) {
    throw KeyError(key.name, "value " + std::to_string(value) + " is out of range");
  } else {
    *static_cast<int*>(field) = static_cast<int>(value);
  }
}

void SetFromToml(const Key& key, const toml::node& node, DaemonConfig* config) {
  void* field = key.field(config);
  const auto wrong_type = [&] {
    std::ostringstream got;
    got << node.type();
    return KeyError(key.name, "expected " + WithArticle(key.type) + ", got " + got.str());
  };
  switch (key.type) {
    case KeyType::kString:
      if (!node.is_string()) throw wrong_type();
      *static_cast<std::string*>(field) = *node.value<std::string>();
      return;
    case KeyType::kPath:
      if (!node.is_string()) throw wrong_type();
      *static_cast<std::filesystem::path*>(field) = *node.value<std::string>();
      return;
    case KeyType::kInt:
    case KeyType::kInt64:
      if (!node.is_integer()) throw wrong_type();
      SetInteger(key, *node.value<int64_t>(), config);
      return;
    case KeyType::kDouble:
      if (!node.is_number()) throw wrong_type();
      *static_cast<double*>(field) = *node.value<double>();
      return;
    case KeyType::kBool:
      if (!node.is_boolean()) throw wrong_type();
      *static_cast<bool*>(field) = *node.value<bool>();
      return;
  }
}

void SetFromText(const Key& key, const std::string& text, DaemonConfig* config) {
  void* field = key.field(config);
  switch (key.type) {
    case KeyType::kString:
      *static_cast<std::string*>(field) = text;
      return;
    case KeyType::kPath:
      *static_cast<std::filesystem::path*>(field) = text;
      return;
    case KeyType::kInt:
    case KeyType::kInt64: {
      const std::optional<int64_t> value = ParseInteger(text);
      if (!value) throw KeyError(key.name, "expected an integer, got '" + text + "'");
      SetInteger(key, *value, config);
      return;
    }
    case KeyType::kDouble: {
      const std::optional<double> value = ParseReal(text);
      if (!value) throw KeyError(key.name, "expected a number, got '" + text + "'");
      *static_cast<double*>(field) = *value;
      return;
    }
    case KeyType::kBool:
      if (text == "true" || text == "1" || text == "yes") {
        *static_cast<bool*>(field) = true;
      } else if (text == "false" || text == "0" || text == "no") {
        *static_cast<bool*>(field) = false;
      } else {
        throw KeyError(key.name, "expected true or false, got '" + text + "'");
      }
      return;
  }
}

void RequireRange(const char* key, int64_t value, int64_t low, int64_t high) {
  if (value < low || value > high) {
    throw KeyError(key, "must be in [" + std::to_string(low) + ", " + std::to_string(high) +
                            "], got " + std::to_string(value));
  }
}

}  // namespace

void Validate(const DaemonConfig& c) {
  if (c.server.listen.empty()) throw KeyError("server.listen", "must not be empty");
  RequireRange("server.port", c.server.port, 0, 65535);
  RequireRange("server.threads", c.server.threads, 2, 256);
  RequireRange("server.control_threads", c.server.control_threads, 1, 64);
  RequireRange("server.max_body_bytes", c.server.max_body_bytes, 1024, 16LL << 30);
  RequireRange("server.max_connections", c.server.max_connections, 8, 65536);
  RequireRange("server.head_timeout_ms", c.server.head_timeout_ms, 100, 600000);
  RequireRange("server.event_stream_s", c.server.event_stream_s, 1, 3600);
  RequireRange("server.max_head_bytes", c.server.max_head_bytes, 1024, 1 << 20);
  if (c.server.allowed_hosts.find_first_of("\r\n") != std::string::npos) {
    throw KeyError("server.allowed_hosts", "must not contain line breaks");
  }
  if (c.server.cors_origin.find_first_of("\r\n") != std::string::npos) {
    throw KeyError("server.cors_origin", "must not contain line breaks");
  }
  const std::string& credential = c.server.token_credential;
  if (credential.find('/') != std::string::npos || credential == "." || credential == "..") {
    throw KeyError("server.token_credential", "must be a credential name, not a path");
  }
  const std::string& source = c.capture.source;
  const size_t colon = source.find(':');
  const std::string scheme = colon == std::string::npos ? "" : source.substr(0, colon);
  if (scheme != "v4l2" && scheme != "libcamera" && scheme != "replay" && scheme != "synthetic") {
    throw KeyError("capture.source", "'" + source +
                                         "' is not v4l2:<device>, libcamera:<id>, "
                                         "replay:<burst dir> or synthetic:");
  }
  RequireRange("capture.width", c.capture.width, 0, 16384);
  RequireRange("capture.height", c.capture.height, 0, 16384);
  if (!(c.capture.fps >= 0.0 && c.capture.fps <= 1000.0)) {
    throw KeyError("capture.fps", "must be in [0, 1000]");
  }
  RequireRange("capture.ring_frames", c.capture.ring_frames, 3, 4096);
  RequireRange("capture.device_buffers", c.capture.device_buffers, 4, 64);
  RequireRange("capture.frame_timeout_ms", c.capture.frame_timeout_ms, 10, 600000);
  RequireRange("capture.reconnect_backoff_ms", c.capture.reconnect_backoff_ms, 0, 600000);
  RequireRange("capture.stall_timeout_ms", c.capture.stall_timeout_ms, 0, 3600000);
  RequireRange("pipeline.frames", c.pipeline.frames, 3, c.capture.ring_frames);
  if (c.pipeline.when != "last" && c.pipeline.when != "next") {
    throw KeyError("pipeline.when",
                   "must be \"last\" or \"next\", got \"" + c.pipeline.when + "\"");
  }
  RequireRange("pipeline.planes", c.pipeline.planes, 2, 1024);
  RequireRange("pipeline.grid", c.pipeline.grid, 0, 4096);
  if (c.pipeline.init != "rank1" && c.pipeline.init != "naive") {
    throw KeyError("pipeline.init",
                   "must be \"rank1\" or \"naive\", got \"" + c.pipeline.init + "\"");
  }
  try {
    ParseRollingShutter(c.pipeline.rolling_shutter);
  } catch (const std::invalid_argument& e) {
    throw KeyError("pipeline.rolling_shutter", e.what());
  }
  RequireRange("pipeline.burst_timeout_ms", c.pipeline.burst_timeout_ms, 1, 600000);
  if (c.calibration.mode != "prior" && c.calibration.mode != "fixed") {
    throw KeyError("calibration.mode",
                   "must be \"prior\" or \"fixed\", got \"" + c.calibration.mode + "\"");
  }
  if (c.calibration.use_fused != "prior" && c.calibration.use_fused != "off") {
    throw KeyError("calibration.use_fused",
                   "must be \"prior\" or \"off\", got \"" + c.calibration.use_fused + "\"");
  }
  if (c.jobs.state_dir.empty()) throw KeyError("jobs.state_dir", "must not be empty");
  RequireRange("jobs.workers", c.jobs.workers, 1, 64);
  RequireRange("jobs.queue", c.jobs.queue, 1, 100000);
  RequireRange("jobs.retry_after_s", c.jobs.retry_after_s, 1, 3600);
  RequireRange("retention.max_jobs", c.retention.max_jobs, 0, 10000000);
  RequireRange("retention.max_bytes", c.retention.max_bytes, 0,
               std::numeric_limits<int64_t>::max());
  RequireRange("retention.max_age_s", c.retention.max_age_s, 0,
               std::numeric_limits<int64_t>::max());
  RequireRange("limits.max_upload_entries", c.limits.max_upload_entries, 3, 1000000);
  RequireRange("limits.max_upload_file_bytes", c.limits.max_upload_file_bytes, 1024, 16LL << 30);
  RequireRange("limits.max_burst_frames", c.limits.max_burst_frames, 3, 100000);
  RequireRange("limits.max_frame_pixels", c.limits.max_frame_pixels, 1, 1LL << 30);
  RequireRange("limits.max_burst_pixels", c.limits.max_burst_pixels, 3, 1LL << 40);
}

std::vector<std::string> ApplyToml(const std::string& text, const std::string& origin,
                                   DaemonConfig* config) {
  std::vector<std::string> applied;
  toml::table root;
  try {
    root = toml::parse(text, origin);
  } catch (const toml::parse_error& e) {
    std::ostringstream message;
    message << origin << ":" << e.source().begin.line << ":" << e.source().begin.column
            << ": not valid TOML: " << e.description();
    throw ConfigError(message.str());
  }
  for (const auto& [section_name, section] : root) {
    const std::string section_key(section_name.str());
    const toml::table* table = section.as_table();
    if (!table) throw KeyError(section_key, "expected a [section], got a value");
    for (const auto& [key_name, value] : *table) {
      const std::string name = section_key + "." + std::string(key_name.str());
      const Key* key = FindKey(name);
      if (!key) throw KeyError(name, "unknown key (see dfsmd --help)");
      SetFromToml(*key, value, config);
      applied.push_back(name);
    }
  }
  return applied;
}

void ApplyFlag(const std::string& name, const std::string& value, DaemonConfig* config) {
  const Key* key = FindKey(name);
  if (!key) throw KeyError("--" + name, "unknown option (see dfsmd --help)");
  SetFromText(*key, value, config);
}

CommandLine ParseCommandLine(const std::vector<std::string>& args) {
  CommandLine line;
  // Pass 1: the file, so flags applied afterwards win whatever their position.
  bool state_dir_set = false;
  for (size_t i = 0; i < args.size(); ++i) {
    std::string arg = args[i];
    if (arg == "--config" || arg.rfind("--config=", 0) == 0) {
      std::string path;
      if (arg == "--config") {
        if (i + 1 >= args.size()) throw ConfigError("--config: needs a file name");
        path = args[++i];
      } else {
        path = arg.substr(9);
      }
      std::ifstream in(path);
      if (!in) throw ConfigError("--config: cannot read '" + path + "'");
      std::ostringstream text;
      text << in.rdbuf();
      const std::string content = text.str();
      for (const std::string& key : ApplyToml(content, path, &line.config)) {
        state_dir_set = state_dir_set || key == "jobs.state_dir";
      }
    }
  }
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--help" || arg == "-h") {
      line.help = true;
      continue;
    }
    if (arg == "--check-config") {
      line.check_only = true;
      continue;
    }
    if (arg == "--config") {
      ++i;
      continue;
    }
    if (arg.rfind("--config=", 0) == 0) continue;
    if (arg.rfind("--", 0) != 0 || arg.size() == 2) {
      throw ConfigError("'" + arg + "': unexpected argument (options are --section.key VALUE)");
    }
    std::string name = arg.substr(2), value;
    const size_t equals = name.find('=');
    if (equals != std::string::npos) {
      value = name.substr(equals + 1);
      name = name.substr(0, equals);
    } else {
      if (i + 1 >= args.size()) throw KeyError("--" + name, "needs a value");
      value = args[++i];
    }
    ApplyFlag(name, value, &line.config);
    state_dir_set = state_dir_set || name == "jobs.state_dir";
  }
  if (!state_dir_set) {
    // systemd's StateDirectory= names the directory it created for us.
    if (const char* dir = std::getenv("STATE_DIRECTORY"); dir && *dir) {
      std::string first(dir);
      first = first.substr(0, first.find(':'));
      line.config.jobs.state_dir = first;
    }
  }
  Validate(line.config);
  if (!line.help) ResolveAccessToken(&line.config.server, std::getenv("CREDENTIALS_DIRECTORY"));
  return line;
}

std::string DescribeKeys() {
  std::ostringstream out;
  const DaemonConfig defaults;
  for (const Key& key : Keys()) {
    DaemonConfig copy = defaults;
    const void* field = key.field(&copy);
    std::string value;
    switch (key.type) {
      case KeyType::kString:
        value = "\"" + *static_cast<const std::string*>(field) + "\"";
        break;
      case KeyType::kPath:
        value = "\"" + static_cast<const std::filesystem::path*>(field)->string() + "\"";
        break;
      case KeyType::kInt:
        value = std::to_string(*static_cast<const int*>(field));
        break;
      case KeyType::kInt64:
        value = std::to_string(*static_cast<const int64_t*>(field));
        break;
      case KeyType::kDouble: {
        std::ostringstream number;
        number << *static_cast<const double*>(field);
        value = number.str();
        break;
      }
      case KeyType::kBool:
        value = *static_cast<const bool*>(field) ? "true" : "false";
        break;
    }
    out << "  --" << key.name << " " << TypeName(key.type) << " (default " << value << ")\n      "
        << key.help << "\n";
  }
  return out.str();
}

}  // namespace dfsm::service
