// Runs a batch: each burst through the pipeline as `dfsm process` would, on
// `jobs` bursts at once, each result made in DIR/.partial/<name>/ and moved to
// DIR/<name>/ when whole, so that an interrupted batch leaves no half result
// that looks complete and a resumed one knows what is done.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "tools/dfsm/batch_inputs.h"
#include "tools/dfsm/batch_progress.h"
#include "tools/dfsm/process_options.h"

namespace dfsm::tools {

struct BatchRunOptions {
  std::filesystem::path out_dir;
  // Bursts in the pipeline at once; memory is about this many bursts' (each
  // burst's frames are read when its turn comes and dropped after).
  int jobs = 1;
  // Skip the bursts whose result is complete (DIR/<name>/summary.json);
  // without it, they are made again and replace the old ones.
  bool resume = false;
  ProcessSettings process;  // as for dfsm process; --frames of a burst or tar
  // The camera every burst's depth uses as a prior, checked against the
  // burst (--calibrate-first, batch_calibration.h); none: each calibrates itself.
  std::optional<KnownCalibration> known;
};

struct BatchReport {
  std::vector<nlohmann::json> lines;  // each burst's summary line, in the items' order
  int ok = 0;
  int failed = 0;
};

// The burst of `item`, at most `max_frames` (0: all) of a burst directory or
// tar (a tar extracted into `scratch`/.burst first); `burst_dir` is set where
// the burst is a directory (its ground truth). Throws BurstError naming the
// input and the problem.
Burst ReadBatchItem(const BatchItem& item, int max_frames, const std::filesystem::path& scratch,
                    std::filesystem::path* burst_dir);

// Whether DIR/<item.name>/ holds a complete result.
bool ResultComplete(const std::filesystem::path& out_dir, const BatchItem& item);

// Runs `items`. Throws what the disk throws (std::system_error,
// std::runtime_error): a result that cannot be written stops the batch.
BatchReport RunBatch(const std::vector<BatchItem>& items, const BatchRunOptions& options,
                     BatchProgress* progress);

}  // namespace dfsm::tools
