#include "daemon/service/job_progress_model.h"

#include <algorithm>
#include <cstring>
#include <numeric>

namespace dfsm::service {
namespace {

struct Lap {
  const char* name;   // as result.json's timings_ms names it
  const char* stage;  // as the job list shows it
  double ms;          // in a 1080p x 10 job on two cores (docs/daemon.md, "Progress")
};

// In the order a job runs them: the processor's loading, the sparse stage's
// laps (core/sparse), the dense stage's (core/dense), the processor's writing.
constexpr Lap kLaps[] = {
    {"loading", "loading", 60},
    {"auto_frames", "auto_frames", 0},  // "frames": "auto" only: the trials (burst_length.h)
    {"features", "features", 257},
    {"known_fit", "sparse", 0},  // under a known calibration only
    {"rotation", "sparse", 1},
    {"rank1", "sparse", 85},
    {"bundle_adjustment", "sparse", 286},
    {"beside_starts", "sparse", 1},
    {"later_starts", "sparse", 387},
    {"reweight", "sparse", 33},
    {"mirrored_relief", "sparse", 40},
    {"self_estimate", "sparse", 0},  // beside a known prior only (also_self_calibrate)
    {"uncertainty", "sparse", 13},
    {"lens_check", "sparse", 9},
    {"angular_velocity", "sparse", 150},  // a self-calibration under a rolling shutter, observed
    {"bias", "sparse", 75},               // a self-calibration's, on the solution kept
    {"frames", "dense", 1},
    {"prepare", "dense", 4},
    {"coarse_sweep", "dense", 316},
    {"coarse_lattice", "dense", 1},
    {"upsample", "dense", 37},
    {"fine_sweep", "dense", 470},
    {"fine_confidence", "dense", 2},
    {"refine", "dense", 63},
    {"fill", "dense", 192},
    {"writing", "writing", 130},
};
constexpr int kLapCount = static_cast<int>(std::size(kLaps));

int LapIndex(const std::string& lap) {
  for (int i = 0; i < kLapCount; ++i)
    if (lap == kLaps[i].name) return i;
  return -1;
}

// `ms` as shares of their sum; equal shares where the sum is 0.
std::vector<double> Shares(std::vector<double> ms) {
  const double total = std::accumulate(ms.begin(), ms.end(), 0.0);
  for (double& share : ms) share = total > 0.0 ? share / total : 1.0 / kLapCount;
  return ms;
}

}  // namespace

JobProgressModel::JobProgressModel() {
  std::vector<double> ms;
  for (const Lap& lap : kLaps) ms.push_back(lap.ms);
  shares_ = Shares(std::move(ms));
}

std::optional<double> JobProgressModel::Progress(const std::string& lap, double fraction) const {
  const int index = LapIndex(lap);
  if (index < 0) return std::nullopt;
  std::lock_guard<std::mutex> lock(mutex_);
  const double before = std::accumulate(shares_.begin(), shares_.begin() + index, 0.0);
  const double progress = before + std::clamp(fraction, 0.0, 1.0) * shares_[index];
  // 1 means finished, which only the job's status says.
  return std::min(progress, 0.99);
}

const char* JobProgressModel::StageOf(const std::string& lap) {
  const int index = LapIndex(lap);
  return index < 0 ? nullptr : kLaps[index].stage;
}

void JobProgressModel::Learn(const std::vector<std::pair<std::string, double>>& laps_ms) {
  std::vector<double> ms(kLapCount, 0.0);
  for (const auto& [lap, lap_ms] : laps_ms) {
    const int index = LapIndex(lap);
    if (index >= 0 && lap_ms > 0.0) ms[index] += lap_ms;
  }
  if (std::accumulate(ms.begin(), ms.end(), 0.0) <= 0.0) return;
  const std::vector<double> measured = Shares(std::move(ms));
  std::lock_guard<std::mutex> lock(mutex_);
  for (int i = 0; i < kLapCount; ++i)
    shares_[i] = (1.0 - kLearningRate) * shares_[i] + kLearningRate * measured[i];
}

}  // namespace dfsm::service
