#include "daemon/service/config_keys.h"

#include <limits>
#include <sstream>
#include <stdexcept>

#include "core/dense/dense_depth.h"
#include "core/sparse/grided_features.h"
#include "daemon/service/number_text.h"

namespace dfsm::service {
namespace {

constexpr int64_t kIntMax = std::numeric_limits<int>::max();
constexpr int64_t kInt64Max = std::numeric_limits<int64_t>::max();

// The capture layer's limits (daemon/capture/capture_limits.h), stated on
// this side of the camera port so that --check-config accepts exactly what
// start-up accepts (dfsmd/config_wiring_test.cc holds them together).
constexpr int kMinRingFrames = 3;
constexpr int kMaxRingFrames = 4096;
constexpr int kMinDeviceBuffers = 4;
constexpr int kMaxDeviceBuffers = 32;

// `member` is a lambda returning a pointer to the key's member.
template <typename Member>
ConfigKey Key(const char* name, KeyType type, Member member, int64_t min, int64_t max,
              const char* help, std::vector<std::string> choices = {}) {
  ConfigKey key;
  key.name = name;
  key.type = type;
  key.min = min;
  key.max = max;
  key.help = help;
  key.choices = std::move(choices);
  key.field = [member](DaemonConfig* c) -> void* { return member(c); };
  return key;
}

template <typename Member>
ConfigKey Text(const char* name, KeyType type, Member member, const char* help,
               std::vector<std::string> choices = {}) {
  return Key(name, type, member, 0, 0, help, std::move(choices));
}

// An enum member whose values, in order, are named by `choices`.
template <typename Member>
ConfigKey Choice(const char* name, Member member, std::vector<std::string> choices,
                 const char* help) {
  using Enum = std::remove_pointer_t<decltype(member(nullptr))>;
  ConfigKey key = Key(name, KeyType::kChoice, member, 0, 0, help, std::move(choices));
  key.get_choice = [member](const DaemonConfig& c) {
    return static_cast<size_t>(*member(const_cast<DaemonConfig*>(&c)));
  };
  key.set_choice = [member](DaemonConfig* c, size_t index) {
    *member(c) = static_cast<Enum>(index);
  };
  return key;
}

#define DFSM_MEMBER(path) [](DaemonConfig* c) { return &c->path; }

std::vector<ConfigKey> MakeKeys() {
  const KeyType kInt = KeyType::kInt, kInt64 = KeyType::kInt64;
  return {
      Text("server.listen", KeyType::kString, DFSM_MEMBER(server.listen), "address to bind"),
      Key("server.port", kInt, DFSM_MEMBER(server.port), 0, 65535, "TCP port (0: any free port)"),
      Key("server.threads", kInt, DFSM_MEMBER(server.threads), 2, 256,
          "HTTP workers for uploads, captures and downloads"),
      Key("server.control_threads", kInt, DFSM_MEMBER(server.control_threads), 1, 64,
          "HTTP workers for probes, status and lists"),
      Key("server.max_body_bytes", kInt64, DFSM_MEMBER(server.max_body_bytes), 1024, 16LL << 30,
          "largest request body (uploads), bytes"),
      Key("server.max_connections", kInt, DFSM_MEMBER(server.max_connections), 8, 65536,
          "connections open at once (the oldest waiting one is closed for a new one)"),
      Key("server.head_timeout_ms", kInt, DFSM_MEMBER(server.head_timeout_ms), 100, 600000,
          "time for a request's line and headers to arrive (else 408)"),
      Key("server.max_head_bytes", kInt, DFSM_MEMBER(server.max_head_bytes), 1024, 1 << 20,
          "largest request line and headers, bytes (else 431)"),
      Key("server.body_grace_ms", kInt, DFSM_MEMBER(server.body_grace_ms), 100, 600000,
          "time a request body may take before server.min_body_rate applies"),
      Key("server.min_body_rate", kInt, DFSM_MEMBER(server.min_body_rate), 1, 1 << 30,
          "least average rate of a request body after server.body_grace_ms, bytes/s "
          "(a slower upload is cut off)"),
      Key("server.event_stream_s", kInt, DFSM_MEMBER(server.event_stream_s), 1, 3600,
          "seconds a GET /api/v1/events stream lasts before the client reconnects"),
      Text("server.allowed_hosts", KeyType::kString, DFSM_MEMBER(server.allowed_hosts),
           "Host names accepted, comma-separated (empty: localhost, host name, listen; "
           "IP addresses always; *: any)"),
      Text("server.cors_origin", KeyType::kString, DFSM_MEMBER(server.cors_origin),
           "Access-Control-Allow-Origin value; empty: CORS off"),
      Text("server.token_file", KeyType::kPath, DFSM_MEMBER(server.token_file),
           "bearer token file (required unless listen is loopback)"),
      Text("server.token_credential", KeyType::kString, DFSM_MEMBER(server.token_credential),
           "systemd credential holding the token when token_file is unset"),
      Text("capture.source", KeyType::kString, DFSM_MEMBER(capture.source),
           "v4l2:/dev/videoN | libcamera:<id> | replay:<burst dir> | synthetic:"),
      Key("capture.width", kInt, DFSM_MEMBER(capture.width), 0, 16384,
          "requested width (0: driver's)"),
      Key("capture.height", kInt, DFSM_MEMBER(capture.height), 0, 16384,
          "requested height (0: driver's)"),
      Key("capture.fps", KeyType::kDouble, DFSM_MEMBER(capture.fps), 0, 1000,
          "requested frame rate (0: default)"),
      Text("capture.pixel_format", KeyType::kString, DFSM_MEMBER(capture.pixel_format),
           "V4L2 fourcc preference, e.g. YUYV; empty: automatic"),
      Text("capture.replay_loop", KeyType::kString, DFSM_MEMBER(capture.replay_loop),
           "replay: restart (a seam no burst spans) | reverse (back and forth, continuous like "
           "a camera)",
           {"restart", "reverse"}),
      Key("capture.ring_frames", kInt, DFSM_MEMBER(capture.ring_frames), kMinRingFrames,
          kMaxRingFrames, "ring buffer, frames"),
      Key("capture.device_buffers", kInt, DFSM_MEMBER(capture.device_buffers), kMinDeviceBuffers,
          kMaxDeviceBuffers, "driver buffers / requests in flight"),
      Key("capture.frame_timeout_ms", kInt, DFSM_MEMBER(capture.frame_timeout_ms), 10, 600000,
          "no frame for this long: reopen the device"),
      Key("capture.reconnect_backoff_ms", kInt, DFSM_MEMBER(capture.reconnect_backoff_ms), 0,
          600000, "wait between reopen attempts"),
      Key("capture.stall_timeout_ms", kInt, DFSM_MEMBER(capture.stall_timeout_ms), 0, 3600000,
          "no frame for this long: stop watchdog pings (0: never)"),
      Key("pipeline.frames", kInt, DFSM_MEMBER(pipeline.frames), 3, kMaxRingFrames,
          "frames per burst (at most capture.ring_frames)"),
      Key("pipeline.max_frames", kInt, DFSM_MEMBER(pipeline.max_frames), 3, kMaxRingFrames,
          "the most frames a \"frames\": \"auto\" capture takes (capture.ring_frames "
          "where that is fewer)"),
      Key("pipeline.auto_parallax_px", KeyType::kDouble, DFSM_MEMBER(pipeline.auto_parallax_px), 0,
          100, "an \"auto\" capture stops once its parallax reaches this, pixels (> 0)"),
      Key("pipeline.still_parallax_px", KeyType::kDouble, DFSM_MEMBER(pipeline.still_parallax_px),
          0, 100,
          "an \"auto\" capture below this at max_frames is refused, and any job's depth from "
          "less is unreliable: move the camera"),
      Choice("pipeline.when", DFSM_MEMBER(pipeline.when),
             {BurstWhenName(BurstWhen::kLast), BurstWhenName(BurstWhen::kNext)},
             "last: frames already in the ring | next: frames still to come"),
      Key("pipeline.planes", kInt, DFSM_MEMBER(pipeline.planes), DenseOptions::kMinPlanes,
          DenseOptions::kMaxPlanes, "plane-sweep depth planes"),
      Key("pipeline.grid", kInt, DFSM_MEMBER(pipeline.grid), 0, GridedFeatureOptions::kMaxCellPx,
          "feature grid cell, pixels (0: scaled with the image)"),
      Choice("pipeline.init", DFSM_MEMBER(pipeline.init),
             {InitModeName(InitMode::kRankOne), InitModeName(InitMode::kNaive)},
             "bundle-adjustment start"),
      Text("pipeline.rolling_shutter", KeyType::kString, DFSM_MEMBER(pipeline.rolling_shutter),
           "global | estimate | readout in [0, 1] of the frame interval"),
      Text("pipeline.dense", KeyType::kBool, DFSM_MEMBER(pipeline.dense),
           "compute the dense depth map"),
      Key("pipeline.burst_timeout_ms", kInt, DFSM_MEMBER(pipeline.burst_timeout_ms), 1, 600000,
          "longest wait for a 'next' burst"),
      Text("calibration.file", KeyType::kPath, DFSM_MEMBER(calibration.file),
           "known calibration for every job (calibration.json/.yaml, OpenCV, ROS); empty: none"),
      Text("calibration.mode", KeyType::kString, DFSM_MEMBER(calibration.mode),
           "how calibration.file enters the adjustment", {"prior", "fixed"}),
      Text("calibration.fuse", KeyType::kBool, DFSM_MEMBER(calibration.fuse),
           "fuse every job's calibration (GET/DELETE /api/v1/calibration)"),
      Text("calibration.use_fused", KeyType::kString, DFSM_MEMBER(calibration.use_fused),
           "prior: jobs use the fused calibration once reliable | off", {"prior", "off"}),
      Key("calibration.joint_bursts", kInt, DFSM_MEMBER(calibration.joint_bursts), 1, 64,
          "the newest jobs of the capture camera a joint calibration adjusts"),
      Key("calibration.joint_every", kInt, DFSM_MEMBER(calibration.joint_every), 0, 10000,
          "a joint calibration after this many new jobs (0: only on POST "
          "/api/v1/calibration/solve)"),
      Text("jobs.state_dir", KeyType::kPath, DFSM_MEMBER(jobs.state_dir),
           "jobs, bursts and results (default $STATE_DIRECTORY or /var/lib/dfsmd)"),
      Key("jobs.workers", kInt, DFSM_MEMBER(jobs.workers), 1, 64, "pipeline jobs run at once"),
      Key("jobs.queue", kInt, DFSM_MEMBER(jobs.queue), 1, 100000,
          "jobs waiting at most; more: 503"),
      Text("jobs.keep_burst", KeyType::kBool, DFSM_MEMBER(jobs.keep_burst),
           "keep each job's burst after success (default of the request field)"),
      Key("jobs.retry_after_s", kInt, DFSM_MEMBER(jobs.retry_after_s), 1, 3600,
          "Retry-After of a 503 when the queue is full"),
      Key("jobs.stall_timeout_s", kInt, DFSM_MEMBER(jobs.stall_timeout_s), 0, 86400,
          "jobs wait or run and none started or finished for this long: stop watchdog pings "
          "(0: never)"),
      Key("retention.max_jobs", kInt, DFSM_MEMBER(retention.max_jobs), 0, 10000000,
          "finished jobs kept at most (0: no limit)"),
      Key("retention.max_bytes", kInt64, DFSM_MEMBER(retention.max_bytes), 0, kInt64Max,
          "bytes of finished jobs kept at most (0: no limit)"),
      Key("retention.max_age_s", kInt64, DFSM_MEMBER(retention.max_age_s), 0, kInt64Max,
          "finished jobs older than this are removed (0: never)"),
      Key("limits.max_upload_entries", kInt, DFSM_MEMBER(limits.max_upload_entries), 3, 1000000,
          "files and directories in one uploaded tar"),
      Key("limits.max_upload_file_bytes", kInt64, DFSM_MEMBER(limits.max_upload_file_bytes), 1024,
          16LL << 30, "largest file in an uploaded tar, bytes"),
      Key("limits.max_burst_frames", kInt, DFSM_MEMBER(limits.max_burst_frames), 3, 100000,
          "frames in an uploaded burst's manifest (and the upload's 'frames' at most)"),
      Key("limits.max_frame_pixels", kInt64, DFSM_MEMBER(limits.max_frame_pixels), 1, 1LL << 30,
          "width x height of one uploaded frame"),
      Key("limits.max_burst_pixels", kInt64, DFSM_MEMBER(limits.max_burst_pixels), 3, 1LL << 40,
          "width x height x frames decoded for one uploaded burst"),
  };
}
#undef DFSM_MEMBER

std::string Quoted(const std::string& text) { return "\"" + text + "\""; }

}  // namespace

ConfigError KeyError(const std::string& key, const std::string& problem) {
  return ConfigError(key + ": " + problem);
}

const char* TypeName(KeyType type) {
  switch (type) {
    case KeyType::kString:
    case KeyType::kPath:
    case KeyType::kChoice:
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

const std::vector<ConfigKey>& ConfigKeys() {
  static const std::vector<ConfigKey> keys = MakeKeys();
  return keys;
}

const ConfigKey* FindConfigKey(std::string_view name) {
  for (const ConfigKey& key : ConfigKeys()) {
    if (name == key.name) return &key;
  }
  return nullptr;
}

const ConfigKey& ConfigKeyNamed(std::string_view name) {
  const ConfigKey* key = FindConfigKey(name);
  if (!key) throw std::logic_error("no configuration key " + std::string(name));
  return *key;
}

std::optional<std::string> ConfigKey::RangeProblem(int64_t value) const {
  if (value >= min && value <= max) return std::nullopt;
  return "must be in [" + std::to_string(min) + ", " + std::to_string(max) + "], got " +
         std::to_string(value);
}

std::optional<std::string> ConfigKey::RangeProblem(double value) const {
  if (value >= static_cast<double>(min) && value <= static_cast<double>(max)) return std::nullopt;
  return "must be in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
}

std::optional<std::string> ConfigKey::ChoiceProblem(const std::string& value) const {
  if (choices.empty()) return std::nullopt;
  std::string list;
  for (size_t i = 0; i < choices.size(); ++i) {
    if (choices[i] == value) return std::nullopt;
    list += (i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ") + Quoted(choices[i]);
  }
  return "must be " + list + ", got " + Quoted(value);
}

size_t ConfigKey::ChoiceIndex(const std::string& value) const {
  if (const auto problem = ChoiceProblem(value)) throw KeyError(name, *problem);
  size_t index = 0;
  while (choices[index] != value) ++index;
  return index;
}

std::optional<std::string> ConfigKey::Problem(const DaemonConfig& config) const {
  DaemonConfig copy = config;  // field() hands out a mutable pointer
  const void* member = field(&copy);
  switch (type) {
    case KeyType::kInt:
      return RangeProblem(static_cast<int64_t>(*static_cast<const int*>(member)));
    case KeyType::kInt64:
      return RangeProblem(*static_cast<const int64_t*>(member));
    case KeyType::kDouble:
      return RangeProblem(*static_cast<const double*>(member));
    case KeyType::kString:
      return ChoiceProblem(*static_cast<const std::string*>(member));
    case KeyType::kPath:
    case KeyType::kChoice:  // an enum holds one of its values
    case KeyType::kBool:
      break;
  }
  return std::nullopt;
}

std::string ConfigKey::ValueText(const DaemonConfig& config) const {
  DaemonConfig copy = config;  // field() hands out a mutable pointer
  const void* member = field(&copy);
  switch (type) {
    case KeyType::kString:
      return Quoted(*static_cast<const std::string*>(member));
    case KeyType::kPath:
      return Quoted(static_cast<const std::filesystem::path*>(member)->string());
    case KeyType::kChoice:
      return Quoted(choices.at(get_choice(config)));
    case KeyType::kInt:
      return std::to_string(*static_cast<const int*>(member));
    case KeyType::kInt64:
      return std::to_string(*static_cast<const int64_t*>(member));
    case KeyType::kDouble: {
      std::ostringstream number;
      number << *static_cast<const double*>(member);
      return number.str();
    }
    case KeyType::kBool:
      return *static_cast<const bool*>(member) ? "true" : "false";
  }
  return "";
}

void ConfigKey::SetFromText(const std::string& text, DaemonConfig* config) const {
  void* member = field(config);
  switch (type) {
    case KeyType::kString:
      *static_cast<std::string*>(member) = text;
      return;
    case KeyType::kPath:
      *static_cast<std::filesystem::path*>(member) = text;
      return;
    case KeyType::kChoice:
      set_choice(config, ChoiceIndex(text));
      return;
    case KeyType::kInt:
    case KeyType::kInt64: {
      const std::optional<int64_t> value = ParseInteger(text);
      if (!value) throw KeyError(name, "expected an integer, got '" + text + "'");
      if (type == KeyType::kInt && (*value < -kIntMax - 1 || *value > kIntMax)) {
        throw KeyError(name, "value " + text + " is out of range");
      }
      if (type == KeyType::kInt) {
        *static_cast<int*>(member) = static_cast<int>(*value);
      } else {
        *static_cast<int64_t*>(member) = *value;
      }
      return;
    }
    case KeyType::kDouble: {
      const std::optional<double> value = ParseReal(text);
      if (!value) throw KeyError(name, "expected a number, got '" + text + "'");
      *static_cast<double*>(member) = *value;
      return;
    }
    case KeyType::kBool:
      if (text == "true" || text == "1" || text == "yes") {
        *static_cast<bool*>(member) = true;
      } else if (text == "false" || text == "0" || text == "no") {
        *static_cast<bool*>(member) = false;
      } else {
        throw KeyError(name, "expected true or false, got '" + text + "'");
      }
      return;
  }
}

}  // namespace dfsm::service
