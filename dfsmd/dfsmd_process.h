// A dfsmd child process for the end-to-end tests and the benchmark: the real binary on a free
// loopback port, its stderr in a log file, stopped with a chosen signal.
#pragma once

#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "core/io/file_util.h"

namespace dfsm::test {

// A port nobody listens on right now (the kernel's choice for port 0).
int FreeLoopbackPort();

class DfsmdProcess {
 public:
  // Starts `binary` with `args` plus --server.port and `env` added to its
  // environment; waits until the camera streams (or, with wait_streaming
  // false, until /healthz answers), at most 20 s. ok() tells whether it came up.
  DfsmdProcess(const std::string& binary, std::vector<std::string> args,
               const std::filesystem::path& log, const std::map<std::string, std::string>& env = {},
               bool wait_streaming = true);
  ~DfsmdProcess();  // SIGKILL if still running

  bool ok() const { return ready_; }
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  httplib::Client Client() const;
  std::string Log() const;

  // Sends `signal` and waits (at most `timeout`) for the exit; returns the
  // exit status, 128 + signal for a signal death, or -1 on timeout.
  int Stop(int signal, std::chrono::seconds timeout = std::chrono::seconds(60));

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  bool ready_ = false;
  std::filesystem::path log_;
};

// Runs dfsmd to completion (for configuration errors); returns the exit status.
int RunDfsmd(const std::string& binary, const std::vector<std::string>& args,
             const std::filesystem::path& log);

}  // namespace dfsm::test
