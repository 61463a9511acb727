// The calibration sweep (core/pipeline/calibration_sweep.h): one JSON line per
// burst, then the summary line. Measures whether sigma_f, the distortion sigma
// and the verdict are honest over the settings a user meets.
//   calibration_sweep [--bursts N] [--seed S] [--no-weak-prior]
#include "core/pipeline/calibration_sweep.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <nlohmann/json.hpp>
#include <vector>

int main(int argc, char** argv) {
  using namespace dfsm;
  int bursts = 64;
  uint64_t seed = 1;
  SparseOptions options;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--bursts") && i + 1 < argc)
      bursts = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--seed") && i + 1 < argc)
      seed = std::strtoull(argv[++i], nullptr, 10);
    else if (!std::strcmp(argv[i], "--no-weak-prior"))
      options.bundle_adjustment.log_f_prior_sigma = 0.0;
    else {
      std::fprintf(stderr, "usage: calibration_sweep [--bursts N] [--seed S] [--no-weak-prior]\n");
      return 2;
    }
  }
  std::vector<SweepOutcome> outcomes;
  for (const SynthOptions& settings : CalibrationSweepSettings(bursts, seed)) {
    outcomes.push_back(RunSweepBurst(settings, options));
    std::printf("%s\n", ToJson(outcomes.back()).dump().c_str());
    std::fflush(stdout);
  }
  std::printf("%s\n", nlohmann::json{{"summary", ToJson(Summarize(outcomes))}}.dump().c_str());
  return 0;
}
