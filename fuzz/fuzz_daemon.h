// The parts of dfsmd that the HTTP harness serves from, assembled by dfsmd's
// own composition root (dfsmd/daemon.h) in a state directory of its own: a
// real job store, a scheduler that is never started (jobs stay queued, no
// pipeline runs), the intake, metrics and a capture service replaying a tiny
// burst. Four
// fixture jobs (processing, succeeded with output files, failed, queued) give
// the job routes something to find.
#pragma once

#include <array>
#include <memory>
#include <string>

#include "dfsmd/daemon.h"
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

  httplib::Server* server() { return parts_->http->server(); }
  const api::HttpServer& http() const { return *parts_->http; }
  size_t max_head_bytes() const {
    return static_cast<size_t>(parts_->config.server.max_head_bytes);
  }
  const std::string& fixture(int index) const { return fixtures_.at(index); }

  // Binds the API to a free loopback port and serves (once); returns the port.
  int Listen();

  // Deletes every job an input made and makes again the fixtures it deleted.
  void Restore();

 private:
  std::string MakeFixture(int index);

  StateDir dir_{"http"};
  std::unique_ptr<daemon::Parts> parts_;
  int port_ = 0;
  std::array<std::string, kFixtures> fixtures_;
};

}  // namespace dfsm::fuzz
