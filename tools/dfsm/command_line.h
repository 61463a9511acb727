// The command lines of dfsm's subcommands, through CLI11 (as dfsm-capture's):
// every option has its help and its check, numbers are read whole ("12abc" is
// an error), and --help prints them.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>

#include "tools/dfsm/command.h"

namespace dfsm::tools {

// Parses `args` (without the program and command names) into `app`'s options.
// Returns 0 after printing --help, nothing when the command should run; a bad
// command line throws UsageError naming the option.
std::optional<int> ParseCommandLine(CLI::App& app, const Args& args);

// --frames: 0 (all of them) or at least the three a burst needs.
CLI::Validator FrameCount();

}  // namespace dfsm::tools
