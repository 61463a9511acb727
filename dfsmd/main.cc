// dfsmd: the depth-from-small-motion camera daemon. See docs/daemon.md.
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "daemon/service/config.h"
#include "dfsmd/daemon.h"

int main(int argc, char** argv) {
  using dfsm::service::ConfigError;
  using dfsm::service::kExitConfig;
  const std::vector<std::string> args(argv + 1, argv + argc);
  dfsm::service::CommandLine line;
  try {
    line = dfsm::service::ParseCommandLine(args);
  } catch (const ConfigError& e) {
    std::cerr << "dfsmd: invalid configuration: " << e.what() << "\n";
    return kExitConfig;
  }
  if (line.help) {
    std::cout << "usage: dfsmd [--config FILE] [--section.key VALUE ...] [--check-config]\n\n"
                 "Keys (also valid in the TOML file as [section] key = value; flags win):\n"
              << dfsm::service::DescribeKeys();
    return 0;
  }
  if (line.check_only) {
    std::cout << "dfsmd: configuration is valid\n";
    return 0;
  }
  try {
    // Before any thread exists: every thread inherits the mask.
    dfsm::daemon::BlockStopSignals();
    const std::unique_ptr<dfsm::daemon::Parts> parts = dfsm::daemon::Assemble(line.config);
    return dfsm::daemon::Serve(*parts);
  } catch (const ConfigError& e) {
    std::cerr << "dfsmd: invalid configuration: " << e.what() << "\n";
    return kExitConfig;
  } catch (const std::exception& e) {
    std::cerr << "dfsmd: fatal: " << e.what() << "\n";
    return 1;
  }
}
