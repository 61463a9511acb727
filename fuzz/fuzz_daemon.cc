#include "fuzz/fuzz_daemon.h"

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <thread>
#include <vector>

#include "api/routes.h"
#include "core/io/burst.h"
#include "core/io/file_util.h"

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

capture::CaptureConfig ToCaptureConfig(const service::CaptureSection& section) {
  capture::CaptureConfig config;
  config.source = section.source;
  config.fps = section.fps;
  config.ring_frames = section.ring_frames;
  config.device_buffers = section.device_buffers;
  config.frame_timeout = std::chrono::milliseconds(section.frame_timeout_ms);
  config.reconnect_backoff = std::chrono::milliseconds(section.reconnect_backoff_ms);
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
  std::vector<unsigned char> bytes;
  cv::imencode(".png", image, bytes);
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

FuzzDaemon::FuzzDaemon() : config_(FuzzConfig(dir_.path())) {
  WriteTinyBurst(dir_.path() / "replay", 8);
  store_ = std::make_unique<service::JobStore>(config_.jobs.state_dir);
  calibration_ =
      std::make_unique<service::CalibrationKeeper>(config_.calibration, config_.jobs.state_dir);
  scheduler_ = std::make_unique<service::JobScheduler>(
      config_.jobs.workers, config_.jobs.queue,
      [](const std::string&, std::shared_ptr<const Burst>) {});  // never started
  capture_ = capture::CaptureService::Create(ToCaptureConfig(config_.capture));
  capture_->Start();

  service::TarLimits tar_limits;  // as daemon.cc derives them from the config
  tar_limits.max_total_bytes = config_.server.max_body_bytes;
  tar_limits.max_file_bytes =
      std::min(config_.limits.max_upload_file_bytes, config_.server.max_body_bytes);
  tar_limits.max_entries = config_.limits.max_upload_entries;
  service::BurstLimits burst_limits;
  burst_limits.max_frames = config_.limits.max_burst_frames;
  burst_limits.max_frame_pixels = config_.limits.max_frame_pixels;
  burst_limits.max_burst_pixels = config_.limits.max_burst_pixels;
  intake_ = std::make_unique<service::JobIntake>(store_.get(), scheduler_.get(), capture_.get(),
                                                 &metrics_, tar_limits, burst_limits);

  http_ = std::make_unique<api::HttpServer>(config_.server);
  api::ApiContext context;
  context.config = &config_;
  context.store = store_.get();
  context.scheduler = scheduler_.get();
  context.intake = intake_.get();
  context.capture = capture_.get();
  context.metrics = &metrics_;
  context.calibration = calibration_.get();
  api::RegisterRoutes(context, http_.get());

  for (int i = 0; i < kFixtures; ++i) fixtures_[i] = MakeFixture(i);
  // Captures and snapshots need frames in the ring: wait for the replay.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (capture_->Status().ring_fill < config_.capture.ring_frames &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

FuzzDaemon::~FuzzDaemon() {
  capture_->Stop();
  scheduler_->Shutdown();
}

std::string FuzzDaemon::MakeFixture(int index) {
  const fs::path burst = store_->NewStagingDir() / "burst";
  WriteTinyBurst(burst, 3);
  const nlohmann::json input = {
      {"width", 16}, {"height", 12}, {"frames", 3}, {"pixel_format", "bgr8"}};
  Job job = store_->Create("upload", service::JobOptions{}, burst, input);
  switch (index) {
    case 0:  // a worker has it (it is not in the queue: DELETE answers 409)
      job.status = JobStatus::kProcessing;
      job.stage = "dense";
      job.started_ms = service::NowUnixMs();
      job.attempts = 1;
      break;
    case 1: {
      const fs::path output = store_->NewStagingDir();
      WriteSucceededOutput(output);
      store_->CommitOutput(job.id, output);
      job.status = JobStatus::kSucceeded;
      job.started_ms = job.finished_ms = service::NowUnixMs();
      job.attempts = 1;
      job.timings_ms = {{"total", 12.5}};
      break;
    }
    case 2: {  // failed, run with keep_burst false: no burst.tar
      const fs::path output = store_->NewStagingDir();
      WriteFileAtomically(
          output / "result.json",
          R"({"format": "dfsm-result/1", "status": "failed", "error": "no parallax"})");
      store_->CommitOutput(job.id, output);
      store_->DropBurst(job.id);
      job.status = JobStatus::kFailed;
      job.error = "no parallax";
      job.has_burst = false;
      job.options.keep_burst = false;
      job.started_ms = job.finished_ms = service::NowUnixMs();
      break;
    }
    default: {  // queued: DELETE takes it out of the queue
      std::optional<service::JobScheduler::Reservation> place = scheduler_->TryReserve();
      if (place) scheduler_->Submit(std::move(*place), job.id, nullptr);
      return job.id;
    }
  }
  store_->Update(job);
  return job.id;
}

void FuzzDaemon::Restore() {
  for (const Job& job : store_->List()) {
    if (std::find(fixtures_.begin(), fixtures_.end(), job.id) != fixtures_.end()) continue;
    scheduler_->RemoveQueued(job.id);
    store_->Remove(job.id);
  }
  for (int i = 0; i < kFixtures; ++i) {
    if (!store_->Get(fixtures_[i])) fixtures_[i] = MakeFixture(i);
  }
}

}  // namespace dfsm::fuzz
