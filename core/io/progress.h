// How far a running pipeline is, for whoever waits on it (dfsmd's job list
// and its page). The pipeline reports each lap of its StageTimers as it ends,
// under the name result.json's timings_ms gives it ("features", "rank1",
// "fine_sweep", ...), with fraction 1; a long lap also reports how much of it
// is done on the way (the features' tracking, frame by frame). The receiver
// turns laps into a share of the whole with the laps' measured durations.
#pragma once

#include <functional>
#include <string>

namespace dfsm {

// Called on the pipeline's thread between steps, so it must return quickly;
// fraction in [0, 1] of the lap `stage`.
using ProgressCallback = std::function<void(const std::string& stage, double fraction)>;

// Reports `done` of `total` steps of `stage` where a callback is set.
inline void ReportProgress(const ProgressCallback& progress, const std::string& stage, int done,
                           int total) {
  if (progress && total > 0)
    progress(stage, done >= total ? 1.0 : static_cast<double>(done) / total);
}

}  // namespace dfsm
