// What `dfsm batch` says of each burst: one line of summary.jsonl (and a row
// of summary.csv) made from the burst's result directory, so that a resumed
// run and a merge of shards say the same of a burst as the run that made it.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tools/dfsm/batch_inputs.h"

namespace dfsm::tools {

// The file in each burst's result directory that holds its summary line; its
// presence marks the result complete (it is written last, before the
// directory is moved into place).
inline constexpr const char* kBurstSummaryFile = "summary.json";

// The burst's line: name, input, status ("ok" | "failed"), error, seconds
// (wall time of the burst in the batch), input frames and size, the
// calibration (f, k1, k2, sigma_f_percent, quality, source), the depth
// verdict, the number of warnings, timings_ms, and `scores` (null where the
// burst has no ground truth). Read from `result_dir`'s result.json.
nlohmann::json SummaryLine(const BatchItem& item, const std::filesystem::path& result_dir,
                           double seconds, const nlohmann::json& scores);

// The scores of a result against a synthetic burst's ground truth (the
// burst directory `burst_dir` holds ground_truth.json): f_error_percent,
// distortion_error_px, mean_rotation_error_deg, and where there is a depth
// map abs_rel, within_25_percent and coverage. Null without ground truth.
nlohmann::json ScoresAgainstTruth(const std::filesystem::path& burst_dir,
                                  const std::filesystem::path& result_dir);

// Writes `lines` as OUT/summary<suffix>.jsonl and OUT/summary<suffix>.csv,
// each atomically.
void WriteSummaries(const std::filesystem::path& out_dir, const std::string& suffix,
                    const std::vector<nlohmann::json>& lines);

// The summary lines of the batch directory `dir`: of its shards
// (summary.shard-I-of-N.jsonl, every I of one N), or where it has none its
// summary.jsonl. Throws std::runtime_error naming a shard whose summary is
// missing (not run, or not finished) or a file that cannot be read.
std::vector<nlohmann::json> ReadBatchSummaries(const std::filesystem::path& dir);

}  // namespace dfsm::tools
