// dfsm batch INPUT... --out DIR: many bursts through the pipeline, with
// progress, resume, a summary, and shards for a cluster's array job;
// dfsm batch --merge DIR... --out DIR joins the shards' summaries.
#include <unistd.h>

#include <cstdio>
#include <map>
#include <thread>

#include "tools/dfsm/batch_calibration.h"
#include "tools/dfsm/batch_inputs.h"
#include "tools/dfsm/batch_runner.h"
#include "tools/dfsm/batch_summary.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"

namespace dfsm::tools {
namespace {

// The summaries of the batch directories `dirs` (each of its shards, or its
// whole batch), each burst once (the first directory that lists it), written
// to `out_dir`.
int Merge(const std::vector<std::string>& dirs, const std::filesystem::path& out_dir) {
  std::map<std::string, nlohmann::json> by_name;
  try {
    for (const std::string& dir : dirs)
      for (nlohmann::json& line : ReadBatchSummaries(dir))
        by_name.emplace(line.value("name", ""), std::move(line));
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "dfsm batch: %s\n", e.what());
    return 1;
  }
  std::vector<nlohmann::json> lines;
  int failed = 0;
  for (auto& [name, line] : by_name) {
    failed += line.value("status", "") != "ok";
    lines.push_back(std::move(line));
  }
  std::filesystem::create_directories(out_dir);
  WriteSummaries(out_dir, "", lines);
  std::printf("dfsm batch: merged %zu bursts (%d failed) into %s/summary.jsonl\n", lines.size(),
              failed, out_dir.c_str());
  return failed > 0 ? 1 : 0;
}

int DefaultJobs() {
  const unsigned cores = std::thread::hardware_concurrency();
  return static_cast<int>(std::max(1u, std::min(cores, 4u)));
}

}  // namespace

int RunBatchCommand(const Args& args) {
  CLI::App app(
      "Runs the pipeline on many bursts: each to DIR/<name>/ as 'dfsm process' writes it, "
      "with DIR/summary.jsonl and DIR/summary.csv.",
      "dfsm batch");
  app.footer(
      "A result is moved into place whole, so an interrupted batch can be resumed with "
      "--resume. On a cluster, each task of an array job runs '--shard I/N' into the same DIR "
      "(summary.shard-I-of-N.*), and '--merge DIR --out DIR' joins them. Exit status: 0 every "
      "burst ok, 1 a burst failed (its result.json says why) or a result could not be written, "
      "2 usage.");
  std::vector<std::string> inputs, merge;
  std::string out_dir, shard_text = "0/1";
  BatchRunOptions options;
  options.jobs = DefaultJobs();
  int window_frames = 0;
  bool calibrate_first_flag = false;
  app.add_option("INPUT", inputs,
                 "dfsm-burst/1 directories, burst.tar files (as dfsmd serves them), videos, "
                 "folders or globs of images, or directories of them (dfsmd job directories "
                 "included)");
  app.add_option("--out", out_dir, "the batch's directory; created when missing")->required();
  app.add_option("--jobs", options.jobs,
                 "bursts processed at once (memory: about this many bursts' frames)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  app.add_flag("--resume", options.resume,
               "skip the bursts whose result is complete (without it they are made again)");
  app.add_option("--shard", shard_text,
                 "process only the I-th of N shards (0 <= I < N): every N-th burst in name order "
                 "from the I-th")
      ->capture_default_str();
  app.add_option("--windows", window_frames,
                 "cut each video, folder or glob of images into consecutive bursts of N frames")
      ->check(FrameCount());
  CLI::Option* calibrate_first = app.add_flag(
      "--calibrate-first", calibrate_first_flag,
      "adjust every burst's tracks jointly first (one camera: 'dfsm calibrate'), into "
      "DIR/calibration/, and give each burst its answer (the joint camera, or the fusion of "
      "the same bursts) as a prior checked against it");
  app.add_option("--merge", merge,
                 "join the summaries of these batch directories (of shards) into --out instead "
                 "of processing")
      ->excludes("INPUT");
  AddProcessOptions(app, &options.process);
  calibrate_first->excludes("--calibration");
  if (const auto status = ParseCommandLine(app, args)) return *status;
  if (!merge.empty()) return Merge(merge, out_dir);
  if (inputs.empty()) throw UsageError("give INPUT bursts, or --merge DIR...");
  Shard shard;
  try {
    shard = ParseShard(shard_text);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--shard: ") + e.what());
  }
  options.out_dir = out_dir;
  std::vector<BatchItem> batch;
  try {
    batch = ExpandBatchInputs(inputs, window_frames);
  } catch (const BurstError& e) {
    std::fprintf(stderr, "dfsm batch: %s\n", e.what());
    return 1;
  }
  if (calibrate_first_flag) {
    std::string said;
    options.known = CalibrateFirst(batch, options, &said);
    std::fprintf(stderr, "dfsm batch: %s\n", said.c_str());
  }
  const std::vector<BatchItem> items = ItemsOfShard(batch, shard);
  int complete = 0;
  if (options.resume)
    for (const BatchItem& item : items) complete += ResultComplete(options.out_dir, item);
  BatchProgress progress(stderr, isatty(STDERR_FILENO) != 0, static_cast<int>(items.size()),
                         complete);
  const BatchReport report = RunBatch(items, options, &progress);
  WriteSummaries(options.out_dir, shard.Suffix(), report.lines);
  progress.Done(report.ok, report.failed);
  std::printf("summary     %s/summary%s.jsonl\n", out_dir.c_str(), shard.Suffix().c_str());
  return report.failed > 0 ? 1 : 0;
}

}  // namespace dfsm::tools
