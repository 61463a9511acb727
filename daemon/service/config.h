// dfsmd's configuration: one table of keys (config_keys.h), read from a TOML
// file and then from command-line flags (flags win). Every key has a default, so an empty
// file and no flags give a working daemon on 127.0.0.1:8080.
//
// Invariant: a DaemonConfig returned by LoadDaemonConfig has passed Validate():
// every value is in range, so the rest of the daemon never re-checks it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/camera/rolling_shutter_options.h"
#include "core/pipeline/burst_length.h"
#include "core/sparse/init_mode.h"
#include "daemon/service/burst_when.h"

namespace dfsm::service {

// A configuration that cannot be used. The message names the key (as written
// in the file, "section.key") and the problem. dfsmd exits with kExitConfig.
class ConfigError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// EX_CONFIG from sysexits.h: systemd's RestartPreventExitStatus=78 keeps a
// misconfigured daemon from restarting in a loop.
inline constexpr int kExitConfig = 78;

struct ServerConfig {
  std::string listen = "127.0.0.1";
  int port = 8080;          // 0: any free port (printed at start-up)
  int threads = 8;          // workers for uploads, captures and downloads (api/request_guard.h)
  int control_threads = 2;  // workers for probes, status and lists: never starved by uploads
  int64_t max_body_bytes = 256LL << 20;
  // The connection gate (api/connection_gate.h): connections open at once,
  // the time and bytes a request head may take.
  int max_connections = 128;
  int head_timeout_ms = 10000;
  int max_head_bytes = 16384;
  // Once a worker serves a request, its body must arrive within
  // body_grace_ms and then at min_body_rate bytes/s on average (api/gate_stream.h).
  int body_grace_ms = 20000;
  int min_body_rate = 500;
  // Host names accepted in the Host header, comma-separated; empty: localhost,
  // this machine's name and the listen address. IP addresses are always
  // accepted; "*" accepts any name (api/request_guard.h, DNS rebinding).
  std::string allowed_hosts;
  // A GET /api/v1/events stream ends after this long (the client reconnects):
  // each stream holds a worker.
  int event_stream_s = 60;
  std::string cors_origin;  // empty: no CORS headers at all
  // Bearer token (access_token.h): read from this file, else from the systemd
  // credential of this name; required unless `listen` is a loopback address.
  std::filesystem::path token_file;
  std::string token_credential = "dfsmd-token";
  std::string token;  // not a key: the secret itself, set by ResolveAccessToken
};

struct CaptureSection {
  std::string source = "replay:";
  int width = 0, height = 0;
  double fps = 0.0;
  std::string pixel_format;
  // A replay: source's loop: "restart" (a seam no burst spans) | "reverse"
  // (back and forth, a continuous stream like a camera's).
  std::string replay_loop = "restart";
  int ring_frames = 64;
  int device_buffers = 4;
  int frame_timeout_ms = 2000;
  int reconnect_backoff_ms = 1000;
  // No frame for this long: capture is stuck and the watchdog pings stop, so
  // systemd restarts the daemon. 0: never.
  int stall_timeout_ms = 20000;
};

struct PipelineSection {
  int frames = 10;
  BurstWhen when = BurstWhen::kLast;
  int planes = 128;
  int grid = 0;  // feature grid cell in pixels; 0: scaled with the image
  InitMode init = InitMode::kRankOne;
  // The camera's readout (core/camera/rolling_shutter.h): "global" |
  // "estimate" | a readout in [0, 1] of the frame interval.
  std::string rolling_shutter = kDefaultRollingShutter;
  bool dense = true;
  int burst_timeout_ms = 5000;  // "next" bursts wait at most this long
  // A capture of "frames": "auto" (core/pipeline/burst_length.h) takes
  // max_frames; its job keeps as few as reach auto_parallax_px of parallax,
  // and fails as too still where all stay below still_parallax_px. Any job's
  // depth map made from less parallax than that is unreliable.
  int max_frames = 30;
  double auto_parallax_px = 2.0;
  double still_parallax_px = kTooStillParallaxPx;
};

// Known and fused calibration (daemon/service/calibration_keeper.h).
struct CalibrationSection {
  // A known calibration (dfsm's calibration.json/.yaml, an OpenCV FileStorage,
  // a ROS CameraInfo YAML) for every job; empty: none.
  std::filesystem::path file;
  std::string mode = "prior";  // "prior" | "fixed": how `file` enters the adjustment
  bool fuse = true;            // fuse each job's calibration into the state directory's
  // "prior": once the fused calibration is reliable, jobs without `file` use it
  // as a prior with its own sigma; "off": every job calibrates alone.
  std::string use_fused = "prior";
  // The joint calibration (docs/daemon.md, Calibration): of the newest
  // `joint_bursts` jobs of the capture camera at one size, made after every
  // `joint_every` new ones (0: only on POST /api/v1/calibration/solve).
  int joint_bursts = 8;
  int joint_every = 4;
};

struct JobsSection {
  std::filesystem::path state_dir = "/var/lib/dfsmd";
  int workers = 1;
  int queue = 8;
  bool keep_burst = true;
  int retry_after_s = 5;
  // Jobs wait or run and none has started or finished for this long: the
  // queue cannot drain (a hung pipeline), and the watchdog stops its pings so
  // that systemd restarts dfsmd (dfsmd/daemon.h). 0: never.
  int stall_timeout_s = 1800;
};

struct RetentionSection {
  int max_jobs = 200;                 // 0: no limit
  int64_t max_bytes = 4LL << 30;      // 0: no limit
  int64_t max_age_s = 7 * 24 * 3600;  // 0: no limit
};

// What one upload may hold (tar_policy.h TarLimits, job_intake.h): refused with a
// 413 or 422 naming the limit before anything is decoded or stored.
struct LimitsSection {
  int max_upload_entries = 4096;
  int64_t max_upload_file_bytes = 256LL << 20;
  int max_burst_frames = 1000;
  // A job's peak memory grows with the size of one frame (the reference's
  // per-pixel images: about 100 bytes a pixel) and with the pixels of the
  // burst (about 6 bytes a pixel). The defaults keep the worst upload they
  // admit, 4K UHD frames or 64 Mi pixels in all (1.2 GB measured), within the
  // unit's MemoryMax=2G beside a 64-frame 1080p ring (docs/memory.md).
  int64_t max_frame_pixels = 8LL << 20;
  // Decoded pixels over all frames kept for the job (a gray8 copy each).
  int64_t max_burst_pixels = 64LL << 20;
};

struct DaemonConfig {
  ServerConfig server;
  CaptureSection capture;
  PipelineSection pipeline;
  CalibrationSection calibration;
  JobsSection jobs;
  RetentionSection retention;
  LimitsSection limits;
};

// Checks every value against the options table's range or choices, and the
// rules that tie keys together; throws ConfigError naming the first bad key.
void Validate(const DaemonConfig& config);

// Applies a TOML document. Unknown sections or keys and values of the wrong
// type are errors (a typo must not silently fall back to a default). Returns
// the keys it set.
std::vector<std::string> ApplyToml(const std::string& text, const std::string& origin,
                                   DaemonConfig* config);

// Applies "--section.key VALUE" / "--section.key=VALUE" flags.
void ApplyFlag(const std::string& key, const std::string& value, DaemonConfig* config);

struct CommandLine {
  DaemonConfig config;
  bool help = false;
  bool check_only = false;  // --check-config: validate and exit
};

// Parses argv: --config FILE first (wherever it appears), then every flag in
// order; $STATE_DIRECTORY (set by systemd's StateDirectory=) is the state_dir
// default when neither the file nor a flag sets it. Validates the result and
// resolves the bearer token (access_token.h) from $CREDENTIALS_DIRECTORY.
CommandLine ParseCommandLine(const std::vector<std::string>& args);

// One line per key: "section.key  type  default  description", for --help and docs.
std::string DescribeKeys();

}  // namespace dfsm::service
