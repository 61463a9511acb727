// The routes on a real server over a real job store, for the API's tests.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "api/http_server.h"
#include "api/routes.h"

namespace dfsm::api {

// A fresh state directory, a job store in it, a scheduler that is never
// started (queued jobs stay queued, so the queue's bounds are testable), the
// intake with the given limits and no capture source, and an HTTP server with
// every route on an ephemeral loopback port. The destructor stops the server
// and the scheduler and removes the directory.
class RoutesTestHarness {
 public:
  // `name` keeps the directories of concurrently running test programs apart.
  RoutesTestHarness(const std::string& name, const service::DaemonConfig& config,
                    const service::TarLimits& tar_limits = {},
                    const service::BurstLimits& burst_limits = {});
  ~RoutesTestHarness();
  RoutesTestHarness(const RoutesTestHarness&) = delete;
  RoutesTestHarness& operator=(const RoutesTestHarness&) = delete;

  int port() const { return port_; }
  const std::filesystem::path& dir() const { return dir_; }
  service::JobStore& store() { return *store_; }
  service::JobScheduler& scheduler() { return *scheduler_; }

  // Stores a job with `status` whose burst directory holds only a manifest.
  std::string AddJob(service::JobStatus status);

 private:
  std::filesystem::path dir_;
  service::DaemonConfig config_;
  service::Metrics metrics_;
  std::unique_ptr<service::JobStore> store_;
  std::unique_ptr<service::JobScheduler> scheduler_;
  std::unique_ptr<service::JobIntake> intake_;
  std::unique_ptr<HttpServer> server_;
  int port_ = 0;
};

// Checks that `result` is a problem+json answer with `status` and a title,
// and returns its detail ("" when there is none).
std::string ExpectProblem(const httplib::Result& result, int status);

}  // namespace dfsm::api
