#include "tools/dfsm/batch_summary.h"

#include <algorithm>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/io/file_util.h"
#include "core/io/ground_truth.h"
#include "tools/dfsm/truth_scores.h"

namespace dfsm::tools {
namespace fs = std::filesystem;
namespace {

nlohmann::json ReadJson(const fs::path& path) {
  try {
    return nlohmann::json::parse(ReadFileToString(path));
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
}

nlohmann::json ReadJsonLine(const fs::path& file, const std::string& line) {
  try {
    return nlohmann::json::parse(line);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(file.string() + ": " + e.what());
  }
}

// What of the calibration a summary needs; null where the burst has none.
nlohmann::json CalibrationOf(const nlohmann::json& result) {
  if (!result.contains("calibration")) return nullptr;
  const nlohmann::json& calibration = result["calibration"];
  const nlohmann::json uncertainty = calibration.value("uncertainty", nlohmann::json::object());
  return {{"f", calibration.value("fx", 0.0)},
          {"k1", calibration.value("k1", 0.0)},
          {"k2", calibration.value("k2", 0.0)},
          {"sigma_f_percent", uncertainty.value("available", false)
                                  ? nlohmann::json(uncertainty.value("sigma_f_percent", 0.0))
                                  : nlohmann::json(nullptr)},
          {"quality", calibration.value("quality", "")},
          {"source", calibration.value("source", "")}};
}

// One CSV field: quoted where it holds a separator, a quote or a line break.
std::string CsvField(const nlohmann::json& value) {
  std::string text;
  if (value.is_null())
    text = "";
  else if (value.is_string())
    text = value.get<std::string>();
  else
    text = value.dump();
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

// summary.csv's columns: each a path into the summary line.
const std::vector<std::pair<std::string, nlohmann::json::json_pointer>>& CsvColumns() {
  using Pointer = nlohmann::json::json_pointer;
  static const std::vector<std::pair<std::string, Pointer>> columns = {
      {"name", Pointer("/name")},
      {"input", Pointer("/input")},
      {"status", Pointer("/status")},
      {"error", Pointer("/error")},
      {"seconds", Pointer("/seconds")},
      {"frames", Pointer("/frames")},
      {"width", Pointer("/width")},
      {"height", Pointer("/height")},
      {"f", Pointer("/calibration/f")},
      {"k1", Pointer("/calibration/k1")},
      {"k2", Pointer("/calibration/k2")},
      {"sigma_f_percent", Pointer("/calibration/sigma_f_percent")},
      {"calibration_quality", Pointer("/calibration/quality")},
      {"calibration_source", Pointer("/calibration/source")},
      {"depth_verdict", Pointer("/depth_verdict")},
      {"warnings", Pointer("/warnings")},
      {"total_ms", Pointer("/timings_ms/total")},
      {"f_error_percent", Pointer("/scores/f_error_percent")},
      {"abs_rel", Pointer("/scores/abs_rel")}};
  return columns;
}

}  // namespace

nlohmann::json SummaryLine(const BatchItem& item, const fs::path& result_dir, double seconds,
                           const nlohmann::json& scores) {
  const nlohmann::json result = ReadJson(result_dir / "result.json");
  const nlohmann::json input = result.value("input", nlohmann::json::object());
  nlohmann::json line = {{"name", item.name},
                         {"input", item.input},
                         {"status", result.value("status", "failed")},
                         {"error", result.value("error", "")},
                         {"seconds", seconds},
                         {"frames", input.value("frames", 0)},
                         {"width", input.value("width", 0)},
                         {"height", input.value("height", 0)},
                         {"calibration", CalibrationOf(result)},
                         {"warnings", result.value("warnings", nlohmann::json::array()).size()},
                         {"timings_ms", result.value("timings_ms", nlohmann::json::object())},
                         {"scores", scores}};
  if (item.frames > 0) line["window"] = {{"start", item.start}, {"frames", item.frames}};
  line["depth_verdict"] = result.contains("depth_verdict")
                              ? nlohmann::json(result["depth_verdict"].value("quality", ""))
                              : nlohmann::json(nullptr);
  return line;
}

nlohmann::json ScoresAgainstTruth(const fs::path& burst_dir, const fs::path& result_dir) {
  if (!HasGroundTruth(burst_dir)) return nullptr;
  const nlohmann::json result = ReadJson(result_dir / "result.json");
  if (result.value("status", "") != "ok") return nullptr;
  const TruthScores scored = ScoreAgainstTruth(burst_dir, result_dir, result);
  nlohmann::json scores = {{"f_error_percent", scored.sparse.focal_error_percent},
                           {"distortion_error_px", scored.sparse.distortion_error_px},
                           {"mean_rotation_error_deg", scored.sparse.mean_rotation_error_deg}};
  if (scored.depth) {
    scores["abs_rel"] = scored.depth->abs_rel;
    scores["within_25_percent"] = scored.depth->within_25_percent;
    scores["coverage"] = scored.depth->coverage;
  }
  return scores;
}

void WriteSummaries(const fs::path& out_dir, const std::string& suffix,
                    const std::vector<nlohmann::json>& lines) {
  std::ostringstream jsonl, csv;
  for (const nlohmann::json& line : lines) jsonl << line.dump() << "\n";
  const auto& columns = CsvColumns();
  for (size_t c = 0; c < columns.size(); ++c) csv << (c ? "," : "") << columns[c].first;
  csv << "\n";
  for (const nlohmann::json& line : lines) {
    for (size_t c = 0; c < columns.size(); ++c) {
      const auto& pointer = columns[c].second;
      csv << (c ? "," : "") << CsvField(line.contains(pointer) ? line[pointer] : nullptr);
    }
    csv << "\n";
  }
  WriteFileAtomically(out_dir / ("summary" + suffix + ".jsonl"), jsonl.str());
  WriteFileAtomically(out_dir / ("summary" + suffix + ".csv"), csv.str());
}

std::vector<nlohmann::json> ReadBatchSummaries(const fs::path& dir) {
  static const std::regex kShardFile(R"(summary\.shard-([0-9]+)-of-([0-9]+)\.jsonl)");
  std::map<int, std::set<int>> shards;  // N -> the I that have a summary
  std::error_code error;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    std::smatch match;
    const std::string name = it->path().filename().string();
    if (std::regex_match(name, match, kShardFile))
      shards[std::stoi(match[2])].insert(std::stoi(match[1]));
  }
  if (error) throw std::runtime_error("cannot list '" + dir.string() + "': " + error.message());
  if (shards.size() > 1)
    throw std::runtime_error(dir.string() + ": summaries of shards of different counts N");
  std::vector<fs::path> files;
  if (shards.empty()) files.push_back(dir / "summary.jsonl");
  for (const auto& [count, present] : shards)
    for (int index = 0; index < count; ++index) {
      const fs::path file = dir / ("summary.shard-" + std::to_string(index) + "-of-" +
                                   std::to_string(count) + ".jsonl");
      if (!present.count(index))
        throw std::runtime_error(file.string() + " is missing: shard " + std::to_string(index) +
                                 " of " + std::to_string(count) + " has not finished");
      files.push_back(file);
    }
  std::vector<nlohmann::json> lines;
  for (const fs::path& file : files) {
    std::istringstream in(ReadFileToString(file));
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) lines.push_back(ReadJsonLine(file, line));
  }
  return lines;
}

}  // namespace dfsm::tools
