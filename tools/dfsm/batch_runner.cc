#include "tools/dfsm/batch_runner.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <fstream>
#include <mutex>
#include <thread>

#include "core/export/calibration_import.h"
#include "core/io/file_util.h"
#include "core/io/image_sequence.h"
#include "core/io/result.h"
#include "daemon/service/tar_extract.h"
#include "tools/dfsm/batch_summary.h"
#include "tools/dfsm/burst_input.h"

namespace dfsm::tools {
namespace fs = std::filesystem;
namespace {

// Extracts the tar `file` into `dir` (new, empty) under dfsmd's rules for an
// uploaded burst: plain files and directories only, within its limits.
void ExtractTarFile(const fs::path& file, const fs::path& dir) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw BurstError(file.string() + ": cannot be opened");
  const service::TarSource source = [&in](char* buffer, size_t size) -> size_t {
    in.read(buffer, static_cast<std::streamsize>(size));
    if (in.bad()) throw std::runtime_error("read error");
    return static_cast<size_t>(in.gcount());
  };
  try {
    service::ExtractTar(source, dir, service::TarLimits{});
  } catch (const service::TarError& e) {
    throw BurstError(file.string() + ": " + e.what());
  }
}

// The pipeline's options for `burst`: the batch's known camera where it has
// one of the burst's size, else --calibration's.
PipelineOptions OptionsFor(const Burst& burst, const BatchRunOptions& options,
                           const PipelineOptions& pipeline) {
  if (!options.known || options.known->camera.width != burst.width() ||
      options.known->camera.height != burst.height())
    return WithKnownCalibration(pipeline, options.process, burst, "dfsm batch");
  PipelineOptions with_known = pipeline;
  with_known.sparse.known = options.known;
  return with_known;
}

// Moves the whole result `partial` to `final_dir`, replacing an old one only
// once the new one is in place beside it.
void PlaceResult(const fs::path& partial, const fs::path& final_dir) {
  std::error_code error;
  if (!fs::exists(final_dir, error)) {
    fs::rename(partial, final_dir);
    return;
  }
  const fs::path replaced = partial.string() + ".replaced";
  fs::remove_all(replaced);
  fs::rename(final_dir, replaced);
  fs::rename(partial, final_dir);
  fs::remove_all(replaced);
}

// One burst through the pipeline into DIR/<name>/; returns its summary line.
nlohmann::json ProcessItem(const BatchItem& item, const BatchRunOptions& options,
                           const PipelineOptions& pipeline) {
  const auto start = std::chrono::steady_clock::now();
  const fs::path partial = options.out_dir / ".partial" / item.name;
  fs::remove_all(partial);  // a run killed before it finished
  fs::create_directories(partial);
  fs::path burst_dir;
  nlohmann::json scores = nullptr;
  // What goes wrong with this burst (its input, its calibration file, the
  // memory it needs) fails it alone; what goes wrong writing stops the batch.
  std::optional<Burst> burst;
  PipelineOutput output;
  try {
    if (!item.error.empty()) throw BurstError(item.error);
    burst = ReadBatchItem(item, options.process.frames, partial, &burst_dir);
    output = RunPipeline(*burst, OptionsFor(*burst, options, pipeline));
  } catch (const std::exception& e) {
    burst.reset();
    output.result.ok = false;
    output.result.error = e.what();
  }
  if (burst)
    WritePipelineOutputs(partial, *burst, &output);
  else
    WriteResultJson(partial, output.result);
  if (!burst_dir.empty()) {
    try {
      scores = ScoresAgainstTruth(burst_dir, partial);
    } catch (const std::exception& e) {
      scores = {{"error", e.what()}};  // damaged ground truth: the result stands
    }
  }
  if (item.tar) fs::remove_all(partial / ".burst");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const nlohmann::json line = SummaryLine(item, partial, seconds, scores);
  WriteFileAtomically(partial / kBurstSummaryFile, line.dump(2) + "\n");
  PlaceResult(partial, options.out_dir / item.name);
  return line;
}

}  // namespace

Burst ReadBatchItem(const BatchItem& item, int max_frames, const fs::path& scratch,
                    fs::path* burst_dir) {
  if (!item.tar) {
    if (!IsImageSequence(item.input)) *burst_dir = item.input;
    return ReadBurstInput(item.input, item.start, item.frames > 0 ? item.frames : max_frames);
  }
  const fs::path extracted = scratch / ".burst";
  fs::remove_all(extracted);
  fs::create_directories(extracted);
  ExtractTarFile(item.input, extracted);
  const std::optional<fs::path> root = service::BurstRootOf(extracted);
  if (!root)
    throw BurstError(item.input +
                     ": the archive has no manifest.json at its top level or in a single "
                     "top-level directory");
  *burst_dir = *root;
  ReadBurstOptions read;
  read.max_frames = max_frames;
  return ReadBurst(*burst_dir, read);
}

bool ResultComplete(const fs::path& out_dir, const BatchItem& item) {
  std::error_code error;
  return fs::is_regular_file(out_dir / item.name / kBurstSummaryFile, error);
}

BatchReport RunBatch(const std::vector<BatchItem>& items, const BatchRunOptions& options,
                     BatchProgress* progress) {
  const PipelineOptions pipeline = ParsedPipelineOptions(options.process);
  fs::create_directories(options.out_dir);
  BatchReport report;
  report.lines.resize(items.size());
  std::vector<size_t> todo;
  for (size_t k = 0; k < items.size(); ++k) {
    if (options.resume && ResultComplete(options.out_dir, items[k]))
      report.lines[k] = nlohmann::json::parse(
          ReadFileToString(options.out_dir / items[k].name / kBurstSummaryFile));
    else
      todo.push_back(k);
  }
  std::atomic<size_t> next{0};
  std::mutex error_mutex;
  std::exception_ptr first_error;
  auto work = [&]() {
    for (size_t t = next++; t < todo.size(); t = next++) {
      const BatchItem& item = items[todo[t]];
      try {
        nlohmann::json line = ProcessItem(item, options, pipeline);
        progress->Finished(item.name, line["status"] == "ok", line["seconds"].get<double>(),
                           line["error"].get<std::string>());
        report.lines[todo[t]] = std::move(line);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!first_error) first_error = std::current_exception();
        next = todo.size();  // the others stop after their burst
      }
    }
  };
  std::vector<std::thread> workers;
  const int jobs = std::max(1, std::min<int>(options.jobs, static_cast<int>(todo.size())));
  for (int j = 1; j < jobs; ++j) workers.emplace_back(work);
  work();
  for (std::thread& worker : workers) worker.join();
  if (first_error) std::rethrow_exception(first_error);
  for (const nlohmann::json& line : report.lines)
    ++(line.value("status", "") == "ok" ? report.ok : report.failed);
  return report;
}

}  // namespace dfsm::tools
