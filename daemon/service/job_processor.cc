#include "daemon/service/job_processor.h"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>

#include "core/io/stage_timer.h"
#include "core/pipeline/pipeline.h"
#include "core/sparse/joint_burst_file.h"
#include "daemon/log/log.h"

namespace dfsm::service {
namespace {

PipelineOptions ToPipelineOptions(const JobOptions& options) {
  PipelineOptions pipeline;
  pipeline.sparse.init = options.init;
  pipeline.sparse.rolling_shutter = ParseRollingShutter(options.rolling_shutter);
  pipeline.sparse.features.cell_px = options.grid;
  pipeline.dense.planes = options.planes;
  pipeline.run_dense = options.dense;
  return pipeline;
}

// The failure of a capture of "frames": "auto" that barely moved.
std::string TooStill(const BurstLength& length, const BurstLengthOptions& options) {
  char message[256];
  std::snprintf(message, sizeof message,
                "move the camera a little: over all %d frames the tracks moved %.2f px beyond "
                "the camera's rotation, and depth needs %.2f px (%.2f px to stop early); hold "
                "it by hand, not on a table",
                length.frames, length.parallax_px, options.min_parallax_px,
                options.target_parallax_px);
  return message;
}

// The warning of a capture of "frames": "auto" that took every frame
// without reaching the parallax it asked for.
std::string LittleMotion(const BurstLength& length, const BurstLengthOptions& options) {
  char message[256];
  std::snprintf(message, sizeof message,
                "little motion: over all %d frames the parallax reached %.2f px of the %.2f px "
                "asked; the depth is coarser than it would be with more motion",
                length.frames, length.parallax_px, options.target_parallax_px);
  return message;
}

}  // namespace

void JobProcessor::Process(const std::string& id, std::shared_ptr<const Burst> preloaded) {
  std::optional<Job> found = store_->Get(id);
  if (!found) {  // deleted while queued
    if (persister_) persister_->Drop(id);
    return;
  }
  Job job = *found;
  try {
    if (job.attempts >= kMaxAttempts) {
      Finish(&job, false,
             "abandoned: processing was interrupted " + std::to_string(job.attempts) + " times");
      return;
    }
    job.status = JobStatus::kProcessing;
    job.started_ms = NowUnixMs();
    job.stage = "loading";
    job.progress = 0.0;
    ++job.attempts;
    store_->Update(job);
    const auto report = [&](const std::string& lap, double fraction) {
      if (const std::optional<double> progress = progress_.Progress(lap, fraction))
        store_->SetProgress(id, JobProgressModel::StageOf(lap), *progress);
    };
    const auto loading_start = std::chrono::steady_clock::now();

    std::shared_ptr<const Burst> burst = preloaded;
    if (!burst && !job.has_burst) {
      // A capture runs on its frames in memory while they are stored beside
      // it (BurstPersister); dfsmd stopped before they were.
      Finish(&job, false,
             "the captured burst was lost: dfsmd stopped before it was stored; trigger a new "
             "capture");
      return;
    }
    if (!burst) {
      ReadBurstOptions read;
      read.max_frames = job.options.frames;
      try {
        burst = std::make_shared<Burst>(ReadBurst(store_->BurstDir(id), read));
      } catch (const BurstError& e) {
        // Uploads are decoded here, not at intake: a corrupt frame fails its
        // job, named as the client named it.
        Finish(&job, false,
               "the burst cannot be read: " +
                   WithoutDirectory(e.what(), store_->BurstDir(id), "the burst"));
        return;
      }
    }
    const double loading_ms = MillisecondsBetween(loading_start);
    report("loading", 1.0);
    PipelineOptions pipeline = ToPipelineOptions(job.options);
    // One bound for too still: a capture of "frames": "auto" fails below it,
    // a map made from less parallax is unreliable.
    pipeline.depth_check.min_parallax_px = burst_length_.min_parallax_px;
    KnownCalibration known;
    if (calibration_ && calibration_->ForJob(job.options, burst->width(), burst->height(), &known))
      pipeline.sparse.known = known;
    std::optional<BurstLength> length;
    if (job.options.auto_frames) {
      length = ChooseBurstLength(*burst, pipeline, burst_length_, report);
      job.input["auto_frames"] = ToJson(*length, burst->size(), burst_length_);
      if (length->reason == BurstLengthReason::kTooStill) {
        Finish(&job, false, TooStill(*length, burst_length_));
        return;
      }
      burst = std::make_shared<Burst>(FramesFromReference(*burst, length->frames));
    }
    PipelineOutput output = RunPipeline(*burst, pipeline, report);
    if (length) {
      output.result.extra["auto_frames"] = job.input["auto_frames"];
      if (length->reason == BurstLengthReason::kAllFrames && output.result.ok &&
          length->trials.back().error.empty())
        output.result.warnings.push_back(LittleMotion(*length, burst_length_));
    }
    if (calibration_ && output.result.ok && output.sparse)
      output.result.extra["calibration_fusion"] =
          calibration_->Record(id, job.options, NowUnixMs(), *output.sparse);
    // A job whose camera was given (a known camera held, no self-calibration
    // beside it) has no calibration of its own to join.
    const bool joins_calibration =
        calibration_ && output.result.ok && output.sparse && output.sparse->OwnCamera();
    report("writing", 0.0);
    const auto writing_start = std::chrono::steady_clock::now();
    const std::filesystem::path staged = store_->NewStagingDir();
    try {
      WritePipelineOutputs(staged, *burst, &output);
      // What a later joint calibration of the camera reads of this job.
      if (joins_calibration)
        WriteJointBurst(staged / kTracksFile, JointBurstOf(id, *output.sparse));
      store_->CommitOutput(id, staged);
    } catch (const std::exception& e) {
      // A full disk must not stay full because of our own leftovers: without
      // the half-written output, the record of the failure still fits.
      std::error_code ignored;
      std::filesystem::remove_all(staged, ignored);
      Finish(&job, false, std::string("cannot store the result: ") + e.what());
      return;
    }
    if (output.result.ok) LearnShares(loading_ms, output, MillisecondsBetween(writing_start));
    job.timings_ms = output.result.timings_ms;
    job.warnings = output.result.warnings;
    job.calibration_quality = output.result.calibration_detail.value("quality", "");
    Finish(&job, output.result.ok, output.result.error);
    if (joins_calibration) JoinCalibration(job, burst->width(), burst->height());
  } catch (const std::exception& e) {
    Finish(&job, false, e.what());
  }
}

void JobProcessor::JoinCalibration(const Job& job, int width, int height) {
  if (!calibration_->RememberTracks(job.id, job.options, width, height)) return;
  try {
    const std::optional<nlohmann::json> joint = calibration_->SolveJoint(
        [this](const std::string& id) { return store_->OutputDir(id) / kTracksFile; });
    if (!joint) return;  // one runs already (POST /api/v1/calibration/solve)
    log::Info("joint calibration after job " + job.id + ": f " +
              std::to_string(joint->at("camera").value("fx", 0.0)) + " px from " +
              std::to_string(joint->at("bursts_joined").get<int>()) + " jobs, " +
              joint->at("verdict").value("quality", ""));
  } catch (const std::exception& e) {
    log::Warning("joint calibration after job " + job.id + ": " + e.what());
  }
}

void JobProcessor::LearnShares(double loading_ms, const PipelineOutput& output, double writing_ms) {
  std::vector<std::pair<std::string, double>> laps = output.result.timings_ms;
  if (output.dense)
    laps.insert(laps.end(), output.dense->timings_ms.begin(), output.dense->timings_ms.end());
  laps.emplace_back("loading", loading_ms);
  laps.emplace_back("writing", writing_ms);
  progress_.Learn(laps);
}

void JobProcessor::Finish(Job* job, bool ok, const std::string& error) {
  try {
    if (ok && !job->options.keep_burst) {
      // A capture's burst still queued for storing is not written at all.
      if (persister_) persister_->Drop(job->id);
      store_->DropBurst(job->id);
    }
    job->status = ok ? JobStatus::kSucceeded : JobStatus::kFailed;
    job->error = ok ? "" : error;
    job->finished_ms = NowUnixMs();
    job->stage = "done";
    store_->Update(*job);  // counts the finished job's bytes
    if (ok) {
      log::Info("job " + job->id + " succeeded");
    } else {
      log::Warning("job " + job->id + " failed: " + error);
    }
    metrics_->JobFinished(ok);
    for (const auto& [stage, ms] : job->timings_ms) metrics_->StageDuration(stage, ms / 1000.0);
    if (job->started_ms > 0) {
      metrics_->JobDuration((job->started_ms - job->created_ms) / 1000.0,
                            (job->finished_ms - job->created_ms) / 1000.0);
    }
    store_->EnforceRetention(retention_, NowUnixMs());
  } catch (const std::exception& e) {
    // The record could not be written (disk full?): the job stays as it was on
    // disk and is retried at the next start.
    log::Error("job " + job->id + ": cannot record the outcome: " + e.what());
  }
}

}  // namespace dfsm::service
