// dfsm-capture: runs one CaptureService from the command line and writes what
// happened as JSON. It is how the VM tests drive real kernel drivers, and a
// quick way to check a camera by hand:
//
//   dfsm-capture --source v4l2:/dev/video0 --fps 30 --duration 5 --burst 10 --out /tmp/b
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>

#include "core/io/burst.h"
#include "daemon/capture/capture_service.h"

namespace {

using dfsm::capture::BurstWhen;
using dfsm::capture::CaptureConfig;
using dfsm::capture::CaptureService;
using dfsm::capture::CaptureStatus;
using Clock = std::chrono::steady_clock;

double CpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec) * 1e-6;
}

struct Arguments {
  CaptureConfig config;
  double duration_s = 0.0;
  double until_reconnected_s = 0.0;
  int burst = 0;
  BurstWhen when = BurstWhen::kNext;
  int timeout_ms = 5000;
  std::string out, report;
  std::string ready_file;  // created once the first frame has arrived
};

// The command line through CLI11: numbers are checked whole ("12abc" is an
// error, not 12), every option has its help, and --help prints them.
void AddOptions(CLI::App& app, Arguments& a) {
  app.description(
      "Streams for --duration seconds (and, with --until-reconnected, until the source has "
      "been lost and found again), then optionally grabs a burst and writes it as "
      "dfsm-burst/1, and prints (or writes) a JSON report.");
  app.add_option("--source", a.config.source,
                 "v4l2:/dev/videoN | libcamera:<id> | replay:<burst dir> | synthetic:")
      ->required();
  app.add_option("--width", a.config.width, "requested width (0: the driver's)")
      ->check(CLI::Range(0, 16384));
  app.add_option("--height", a.config.height, "requested height (0: the driver's)")
      ->check(CLI::Range(0, 16384));
  app.add_option("--fps", a.config.fps,
                 "requested frame rate (0: the default; a replay at -1: as fast as read)")
      ->check(CLI::Range(-1.0, 1000.0));
  app.add_option("--format", a.config.pixel_format, "V4L2 fourcc preference, e.g. YUYV");
  app.add_option("--ring", a.config.ring_frames, "ring buffer, frames");
  app.add_option("--buffers", a.config.device_buffers, "driver buffers / requests in flight");
  app.add_flag_callback(
      "--gray", [&a] { a.config.keep_color = false; }, "keep gray frames only");
  app.add_option_function<int>(
         "--frame-timeout-ms",
         [&a](int ms) { a.config.frame_timeout = std::chrono::milliseconds(ms); },
         "no frame for this long: reopen")
      ->check(CLI::Range(1, 3600000));
  app.add_option_function<int>(
         "--backoff-ms",
         [&a](int ms) { a.config.reconnect_backoff = std::chrono::milliseconds(ms); },
         "wait between reopen attempts")
      ->check(CLI::Range(0, 3600000));
  app.add_option("--duration", a.duration_s, "seconds to stream, from the first frame")
      ->check(CLI::Range(0.0, 86400.0));
  app.add_option("--until-reconnected", a.until_reconnected_s,
                 "also wait this long for the source to be lost and found again")
      ->check(CLI::Range(0.0, 86400.0));
  app.add_option("--burst", a.burst, "frames of a burst to grab at the end (0: none)")
      ->check(CLI::Range(0, 3600000));
  app.add_option_function<std::string>(
         "--when",
         [&a](const std::string& when) {
           a.when = when == "last" ? BurstWhen::kLast : BurstWhen::kNext;
         },
         "last: frames already in the ring | next: frames to come (default)")
      ->check(CLI::IsMember({"last", "next"}));
  app.add_option("--timeout-ms", a.timeout_ms, "longest wait for a 'next' burst")
      ->check(CLI::Range(1, 3600000));
  app.add_option("--out", a.out, "write the burst here (dfsm-burst/1)");
  app.add_option("--report", a.report, "write the JSON report here (default: stdout)");
  app.add_option("--ready-file", a.ready_file, "created once the first frame has arrived");
}

}  // namespace

int main(int argc, char** argv) {
  Arguments args;
  CLI::App app("dfsm-capture: one capture service from the command line", "dfsm-capture");
  AddOptions(app, args);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help exits 0 with the options; a bad command line exits 2 naming it.
    const int status = app.exit(e);
    return status == 0 ? 0 : 2;
  }
  nlohmann::json report = {{"ok", false}};
  int exit_code = 1;
  try {
    auto service = CaptureService::Create(args.config);
    const auto start = Clock::now();
    const double cpu_start = CpuSeconds();
    service->Start();

    // The duration counts from the first frame (opening a device and filling
    // the ring can take seconds on a slow machine). The status is sampled to
    // see outages, how long they lasted, and every error shown meanwhile.
    nlohmann::json outage = nlohmann::json::object();
    nlohmann::json errors = nlohmann::json::array();
    Clock::time_point lost_at{};
    bool lost = false, recovered = false;
    const auto first_frame_limit = start + std::chrono::seconds(60);
    while (service->Status().frames_captured == 0 && Clock::now() < first_frame_limit) {
      const CaptureStatus s = service->Status();
      if (!s.last_error.empty() && (errors.empty() || errors.back() != s.last_error))
        errors.push_back(s.last_error);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    const auto first_frame = Clock::now();
    if (!args.ready_file.empty()) std::ofstream(args.ready_file) << "streaming\n";
    report["first_frame_s"] = std::chrono::duration<double>(first_frame - start).count();
    const CaptureStatus at_first = service->Status();
    // Steady state: after one second of streaming.
    const auto warm = first_frame + std::chrono::seconds(1);
    std::optional<CaptureStatus> at_warm;
    double cpu_warm = 0.0;
    Clock::time_point warm_at{};
    const auto stream_until = first_frame + std::chrono::duration<double>(args.duration_s);
    const auto give_up = stream_until + std::chrono::duration<double>(args.until_reconnected_s);
    while (Clock::now() < give_up) {
      const CaptureStatus s = service->Status();
      if (!s.last_error.empty() && (errors.empty() || errors.back() != s.last_error))
        errors.push_back(s.last_error);
      if (!at_warm && Clock::now() >= warm) {
        at_warm = s;
        cpu_warm = CpuSeconds();
        warm_at = Clock::now();
      }
      if (!lost && s.frames_captured > 0 && !s.streaming) {
        lost = true;
        lost_at = Clock::now();
      }
      if (lost && !recovered && s.streaming && s.reconnects > 0) {
        recovered = true;
        outage["recovery_s"] = std::chrono::duration<double>(Clock::now() - lost_at).count();
      }
      if (Clock::now() >= stream_until && (args.until_reconnected_s <= 0 || recovered)) break;
      // Coarse: the sampling must not compete with capture for the CPU.
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    report["errors_seen"] = errors;
    const CaptureStatus streamed = service->Status();
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    report["after_streaming"] = ToJson(streamed);
    report["elapsed_s"] = elapsed;
    report["cpu_s"] = CpuSeconds() - cpu_start;
    if (at_warm && streamed.frames_captured > at_warm->frames_captured) {
      const double seconds = std::chrono::duration<double>(Clock::now() - warm_at).count();
      const uint64_t frames = streamed.frames_captured - at_warm->frames_captured;
      report["steady"] = {
          {"seconds", seconds},
          {"frames", frames},
          {"dropped", streamed.frames_dropped - at_warm->frames_dropped},
          {"fps", static_cast<double>(frames) / seconds},
          {"cpu_ms_per_frame", 1000.0 * (CpuSeconds() - cpu_warm) / static_cast<double>(frames)}};
    }
    report["dropped_before_first_frame"] = at_first.frames_dropped;

    report["mean_fps"] =
        elapsed > 0 ? static_cast<double>(streamed.frames_captured) / elapsed : 0.0;
    if (args.until_reconnected_s > 0) {
      outage["lost"] = lost;
      outage["recovered"] = recovered;
      report["outage"] = outage;
    }

    if (args.burst > 0) {
      const auto grab_start = Clock::now();
      CaptureService::Burst burst =
          service->GrabBurst(args.burst, args.when, std::chrono::milliseconds(args.timeout_ms));
      report["burst"] = {
          {"frames", burst.frames.size()},
          {"grab_s", std::chrono::duration<double>(Clock::now() - grab_start).count()},
          {"manifest", dfsm::ToJson(burst.manifest)}};
      if (!args.out.empty()) {
        dfsm::WriteBurst(args.out, burst.manifest, burst.frames);
        report["burst"]["dir"] = args.out;
      }
    }
    report["final"] = ToJson(service->Status());
    service->Stop();
    report["ok"] = args.until_reconnected_s <= 0 || recovered;
    exit_code = report["ok"].get<bool>() ? 0 : 1;
  } catch (const std::exception& e) {
    report["error"] = e.what();
    std::cerr << "dfsm-capture: " << e.what() << "\n";
  }
  const std::string text = report.dump(2) + "\n";
  if (args.report.empty()) {
    std::cout << text;
  } else {
    std::ofstream file(args.report);
    file << text;
    if (!file) {
      std::cerr << "dfsm-capture: cannot write " << args.report << "\n";
      return 1;
    }
  }
  return exit_code;
}
