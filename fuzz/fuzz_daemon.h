// The parts of dfsmd that the HTTP harness serves from, put together as
// daemon/service/daemon.cc does, in a state directory of its own: a real job
// store, a scheduler that is never started (jobs stay queued, no pipeline runs),
// the intake, metrics and a capture service replaying a tiny burst. Four
// fixture jobs (processing, succeeded with output files, failed, queued) give
// the job routes something to find.
#pragma once

#include <array>
#include <memory>
#include <string>

#include "api/http_server.h"
#include "daemon/capture/capture_service.h"
#include "daemon/service/calibration_keeper.h"
#include "daemon/service/config.h"
#include "daemon/service/job_intake.h"
#include "daemon/service/job_scheduler.h"
#include "daemon/service/job_store.h"
#include "daemon/service/metrics.h"
#include "fuzz/state_dir.h"

namespace dfsm::fuzz {

// The bearer token the harness configures; seeds send it.
inline constexpr const char* kFuzzToken = "fuzz-token";

class FuzzDaemon {
 public:
  static constexpr int kFixtures = 4;

  FuzzDaemon();
  ~FuzzDaemon();
  FuzzDaemon(const FuzzDaemon&) = delete;
  FuzzDaemon& operator=(const FuzzDaemon&) = delete;

  httplib::Server* server() { return http_->server(); }
  const api::HttpServer& http() const { return *http_; }
  size_t max_head_bytes() const { return static_cast<size_t>(config_.server.max_head_bytes); }
  const std::string& fixture(int index) const { return fixtures_.at(index); }

  // Deletes every job an input made and makes again the fixtures it deleted.
  void Restore();

 private:
  std::string MakeFixture(int index);

  StateDir dir_{"http"};
  service::DaemonConfig config_;
  service::Metrics metrics_;
  std::unique_ptr<service::JobStore> store_;
  std::unique_ptr<service::CalibrationKeeper> calibration_;
  std::unique_ptr<service::JobScheduler> scheduler_;
  std::unique_ptr<capture::CaptureService> capture_;
  std::unique_ptr<service::JobIntake> intake_;
  std::unique_ptr<api::HttpServer> http_;
  std::array<std::string, kFixtures> fixtures_;
};

}  // namespace dfsm::fuzz
