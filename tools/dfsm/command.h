// Subcommands of the `dfsm` tool. Each lives in its own <name>_command.cc and
// returns the process exit status (0 ok, 1 processing failed, 2 usage error).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace dfsm::tools {

// A bad command line: main prints it and exits 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

using Args = std::vector<std::string>;

int RunProcessCommand(const Args& args);
int RunSynthCommand(const Args& args);
int RunEvaluateCommand(const Args& args);
int RunCalibrateCommand(const Args& args);
int RunBatchCommand(const Args& args);
int RunShowCommand(const Args& args);

}  // namespace dfsm::tools
