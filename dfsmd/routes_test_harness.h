// The routes on a real server over the assembled parts (dfsmd/daemon.h), for
// the API's tests.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "api/routes.h"
#include "dfsmd/daemon.h"

namespace dfsm::api {

// A fresh state directory and dfsmd's parts assembled in it from `config`
// (its state_dir replaced), without a camera and with the workers never
// started (queued jobs stay queued, so the queue's bounds are testable); the
// HTTP server serves every route on an ephemeral loopback port. The
// destructor stops everything and removes the directory.
class RoutesTestHarness {
 public:
  // `name` keeps the directories of concurrently running test programs apart.
  RoutesTestHarness(const std::string& name, service::DaemonConfig config);
  ~RoutesTestHarness();
  RoutesTestHarness(const RoutesTestHarness&) = delete;
  RoutesTestHarness& operator=(const RoutesTestHarness&) = delete;

  int port() const { return port_; }
  const std::filesystem::path& dir() const { return dir_; }
  service::JobStore& store() { return *parts_->store; }
  service::JobScheduler& scheduler() { return *parts_->scheduler; }
  daemon::Parts& parts() { return *parts_; }

  // Stores a job with `status` whose burst directory holds only a manifest.
  std::string AddJob(service::JobStatus status);

 private:
  std::filesystem::path dir_;
  std::unique_ptr<daemon::Parts> parts_;
  int port_ = 0;
};

// Checks that `result` is a problem+json answer with `status` and a title,
// and returns its detail ("" when there is none).
std::string ExpectProblem(const httplib::Result& result, int status);

}  // namespace dfsm::api
