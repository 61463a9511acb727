// dfsm: depth from small motion on recorded bursts.
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "tools/dfsm/command.h"

namespace {

constexpr const char* kUsage =
    "usage: dfsm <command> [options]\n"
    "\n"
    "commands:\n"
    "  process BURST --out DIR [options]\n"
    "        run the pipeline on a burst or a folder of images, write a dfsm-result/1 directory\n"
    "  synth --out DIR [options]\n"
    "        render a handheld small-motion burst of a textured scene with ground truth\n"
    "  batch INPUT... --out DIR [options]\n"
    "        run the pipeline on many bursts, with progress, resume, a summary and shards\n"
    "  calibrate BURST... --out DIR [options]\n"
    "        calibrate one camera from several of its bursts (fused, with sigma)\n"
    "  show RESULT [--truth BURST]\n"
    "        a result in a few lines: camera, depth, warnings, time, files (and scores)\n"
    "  evaluate --result DIR --truth BURST\n"
    "        compare a result against a synthetic burst's ground truth (prints JSON)\n"
    "\n"
    "Run 'dfsm <command> --help' for the options of one command.\n";

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  const std::string command = argv[1];
  const dfsm::tools::Args args(argv + 2, argv + argc);
  try {
    if (command == "process") return dfsm::tools::RunProcessCommand(args);
    if (command == "synth") return dfsm::tools::RunSynthCommand(args);
    if (command == "evaluate") return dfsm::tools::RunEvaluateCommand(args);
    if (command == "calibrate") return dfsm::tools::RunCalibrateCommand(args);
    if (command == "batch") return dfsm::tools::RunBatchCommand(args);
    if (command == "show") return dfsm::tools::RunShowCommand(args);
  } catch (const dfsm::tools::UsageError& e) {
    std::fprintf(stderr, "dfsm %s: %s\n", command.c_str(), e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dfsm %s: %s\n", command.c_str(), e.what());
    return 1;
  }
  std::fprintf(stderr, "dfsm: unknown command '%s'\n\n%s", command.c_str(), kUsage);
  return 2;
}
