#include "fuzz/fuzz_daemon.h"

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "core/io/burst.h"
#include "core/io/file_util.h"
#include "core/io/png_encode.h"

namespace dfsm::fuzz {
namespace {

namespace fs = std::filesystem;
using service::Job;
using service::JobStatus;

// Small everything: a request can then never be slow because of the config.
service::DaemonConfig FuzzConfig(const fs::path& state_dir) {
  service::DaemonConfig config;
  config.server.port = 0;
  config.server.max_body_bytes = 256 << 10;
  config.server.cors_origin = "https://viewer.example";  // CORS routes on
  config.server.token = kFuzzToken;                      // bearer auth on
  config.server.event_stream_s = 1;      // an input that opens the event stream ends in 1 s
  config.server.head_timeout_ms = 1000;  // a partial head ends in 1 s (the socket harness)
  config.capture.source = "replay:" + (state_dir / "replay").string();
  config.capture.fps = 250;  // a "next" burst of 4 frames arrives in 16 ms
  config.capture.ring_frames = 16;
  config.pipeline.frames = 4;
  config.pipeline.burst_timeout_ms = 100;
  config.jobs.state_dir = state_dir / "state";
  config.jobs.queue = 6;
  config.limits.max_upload_entries = 64;
  config.limits.max_burst_frames = 32;
  config.limits.max_frame_pixels = 256 * 256;
  config.limits.max_burst_pixels = 1 << 20;
  service::Validate(config);
  return config;
}

// A tiny textured colour burst, as a camera would have stored it.
void WriteTinyBurst(const fs::path& dir, int frames) {
  BurstManifest manifest;
  manifest.width = 16;
  manifest.height = 12;
  manifest.pixel_format = "bgr8";
  std::vector<cv::Mat> images;
  cv::RNG rng(7);
  for (int i = 0; i < frames; ++i) {
    cv::Mat image(manifest.height, manifest.width, CV_8UC3);
    rng.fill(image, cv::RNG::UNIFORM, 0, 256);
    images.push_back(image);
    manifest.frames.push_back({"", int64_t{i} * 4000000, i});
  }
  WriteBurst(dir, manifest, images);
}

std::string Png(const cv::Mat& image) {
  const std::vector<unsigned char> bytes = EncodePng(image, PngCompression::kCompact);
  return std::string(bytes.begin(), bytes.end());
}

// The files of a successful job's output (a few are left out on purpose:
// "did not produce" is a route outcome too).
void WriteSucceededOutput(const fs::path& dir) {
  const nlohmann::json calibration = {
      {"width", 16}, {"height", 12}, {"fx", 20.0},
      {"fy", 20.0},  {"cx", 8.0},    {"cy", 6.0},
      {"k1", -0.01}, {"k2", 0.001},  {"distortion_model", "ha2016-d2u"}};
  const nlohmann::json result = {{"format", "dfsm-result/1"},
                                 {"status", "ok"},
                                 {"calibration", calibration},
                                 {"bundle_adjustment", {{"rms_reprojection_px", 0.12}}}};
  WriteFileAtomically(dir / "result.json", result.dump(2));
  WriteFileAtomically(dir / "calibration.json", calibration.dump(2));
  WriteFileAtomically(dir / "calibration.yaml", "%YAML:1.0\n---\ncamera_matrix: []\n");
  WriteFileAtomically(dir / "depth.png", Png(cv::Mat(12, 16, CV_16UC1, cv::Scalar(1000))));
  WriteFileAtomically(dir / "confidence.png", Png(cv::Mat(12, 16, CV_8UC1, cv::Scalar(200))));
  WriteFileAtomically(dir / "points.ply", "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n");
}

}  // namespace

FuzzDaemon::FuzzDaemon() {
  const service::DaemonConfig config = FuzzConfig(dir_.path());
  WriteTinyBurst(dir_.path() / "replay", 8);
  // dfsmd's own assembly, with the workers never started: queued jobs stay
  // queued (the fixtures rely on it) and no pipeline runs per input.
  daemon::AssembleOptions options;
  options.recover = false;
  options.start_workers = false;
  parts_ = daemon::Assemble(config, options);

  for (int i = 0; i < kFixtures; ++i) fixtures_[i] = MakeFixture(i);
  // Captures and snapshots need frames in the ring: wait for the replay.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (parts_->capture->Status().ring_fill < config.capture.ring_frames &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

FuzzDaemon::~FuzzDaemon() = default;

int FuzzDaemon::Listen() {
  if (port_ == 0) {
    port_ = parts_->http->Bind();
    parts_->http->Start();
  }
  return port_;
}

std::string FuzzDaemon::MakeFixture(int index) {
  const fs::path burst = parts_->store->NewStagingDir() / "burst";
  WriteTinyBurst(burst, 3);
  const nlohmann::json input = {
      {"width", 16}, {"height", 12}, {"frames", 3}, {"pixel_format", "bgr8"}};
  Job job = parts_->store->Create("upload", service::JobOptions{}, burst, input);
  switch (index) {
    case 0:  // a worker has it (it is not in the queue: DELETE answers 409)
      job.status = JobStatus::kProcessing;
      job.stage = "dense";
      job.started_ms = service::NowUnixMs();
      job.attempts = 1;
      break;
    case 1: {
      const fs::path output = parts_->store->NewStagingDir();
      WriteSucceededOutput(output);
      parts_->store->CommitOutput(job.id, output);
      job.status = JobStatus::kSucceeded;
      job.started_ms = job.finished_ms = service::NowUnixMs();
      job.attempts = 1;
      job.timings_ms = {{"total", 12.5}};
      break;
    }
    case 2: {  // failed, run with keep_burst false: no burst.tar
      const fs::path output = parts_->store->NewStagingDir();
      WriteFileAtomically(
          output / "result.json",
          R"({"format": "dfsm-result/1", "status": "failed", "error": "no parallax"})");
      parts_->store->CommitOutput(job.id, output);
      parts_->store->DropBurst(job.id);
      job.status = JobStatus::kFailed;
      job.error = "no parallax";
      job.has_burst = false;
      job.options.keep_burst = false;
      job.started_ms = job.finished_ms = service::NowUnixMs();
      break;
    }
    default: {  // queued: DELETE takes it out of the queue
      std::optional<service::JobScheduler::Reservation> place = parts_->scheduler->TryReserve();
      if (place) parts_->scheduler->Submit(std::move(*place), job.id, nullptr);
      return job.id;
    }
  }
  parts_->store->Update(job);
  return job.id;
}

void FuzzDaemon::Restore() {
  for (const Job& job : parts_->store->List()) {
    if (std::find(fixtures_.begin(), fixtures_.end(), job.id) != fixtures_.end()) continue;
    parts_->scheduler->RemoveQueued(job.id);
    parts_->store->Remove(job.id);
  }
  for (int i = 0; i < kFixtures; ++i) {
    if (!parts_->store->Get(fixtures_[i])) fixtures_[i] = MakeFixture(i);
  }
}

}  // namespace dfsm::fuzz
