#include "daemon/service/job_progress_model.h"

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "core/pipeline/burst_length.h"
#include "core/pipeline/pipeline.h"
#include "core/synth/burst_synthesizer.h"

namespace dfsm::service {
namespace {

Burst SmallGeneratedBurst() {
  SynthOptions options;
  options.width = 320;
  options.height = 240;
  options.frames = 8;
  return ToBurst(SynthesizeBurst(options));
}

// What a job's progress reads through the model, report by report, while a
// real pipeline runs.
struct Reports {
  std::vector<std::string> laps;
  std::vector<double> progress;
};

Reports RunReported(const Burst& burst, const PipelineOptions& options,
                    const JobProgressModel& model, PipelineOutput* output) {
  Reports reports;
  *output = RunPipeline(burst, options, [&](const std::string& lap, double fraction) {
    reports.laps.push_back(lap);
    const std::optional<double> progress = model.Progress(lap, fraction);
    EXPECT_TRUE(progress) << "the pipeline reports a lap the model does not know: " << lap;
    EXPECT_NE(JobProgressModel::StageOf(lap), nullptr) << lap;
    if (progress) reports.progress.push_back(*progress);
  });
  return reports;
}

void ExpectRising(const Reports& reports) {
  ASSERT_GE(reports.progress.size(), 8u);
  for (size_t i = 1; i < reports.progress.size(); ++i)
    EXPECT_GE(reports.progress[i], reports.progress[i - 1])
        << reports.laps[i] << " after " << reports.laps[i - 1];
  EXPECT_LT(reports.progress.back(), 1.0);
}

// The model's order of the laps is the pipeline's: a lap the pipeline renames
// or reorders would make a job's progress stall or jump back.
TEST(JobProgressModel, KnowsEveryLapOfARealJobInTheOrderTheyRun) {
  const JobProgressModel model;
  PipelineOptions options;
  options.dense.planes = 32;
  PipelineOutput output;
  const Reports reports = RunReported(SmallGeneratedBurst(), options, model, &output);
  ASSERT_TRUE(output.result.ok) << output.result.error;
  ExpectRising(reports);
  EXPECT_EQ(JobProgressModel::StageOf(reports.laps.front()), std::string("features"));
  EXPECT_EQ(JobProgressModel::StageOf(reports.laps.back()), std::string("dense"));
  EXPECT_GT(*model.Progress("writing", 0.0), reports.progress.back() - 1e-12);
}

// A "frames": "auto" job first tries lengths of its burst (burst_length.h):
// its own stage, before the features of the run that follows.
TEST(JobProgressModel, PlacesTheAutoFramesTrialsBeforeTheRun) {
  JobProgressModel model;
  model.Learn({{kBurstLengthLap, 900.0}, {"features", 100.0}, {"dense", 500.0}});
  std::vector<double> progress;
  const Burst burst = SmallGeneratedBurst();
  PipelineOptions options;
  options.run_dense = false;
  BurstLengthOptions lengths;
  lengths.lengths = {4, 6};
  lengths.target_parallax_px = 1000.0;  // every length is tried
  ChooseBurstLength(burst, options, lengths, [&](const std::string& lap, double fraction) {
    EXPECT_STREQ(JobProgressModel::StageOf(lap), "auto_frames");
    progress.push_back(*model.Progress(lap, fraction));
  });
  ASSERT_EQ(progress.size(), 3u);  // 4, 6, then all 8 frames
  EXPECT_GT(progress.front(), *model.Progress("loading", 1.0));
  EXPECT_LT(progress[0], progress[1]);
  EXPECT_DOUBLE_EQ(progress.back(), *model.Progress("features", 0.0));
}

// Under a known calibration the burst is first calibrated alone on the same
// tracks (the known-fit check): one lap, then the adjustment's laps.
TEST(JobProgressModel, FollowsAJobUnderAKnownCalibration) {
  const JobProgressModel model;
  SynthOptions synth;
  synth.width = 320;
  synth.height = 240;
  synth.frames = 8;
  const SynthBurst generated = SynthesizeBurst(synth);
  PipelineOptions options;
  options.run_dense = false;
  KnownCalibration known;
  known.camera = generated.truth.camera;
  options.sparse.known = known;
  PipelineOutput output;
  const Reports reports = RunReported(ToBurst(generated), options, model, &output);
  ASSERT_TRUE(output.result.ok) << output.result.error;
  ExpectRising(reports);
  EXPECT_NE(std::find(reports.laps.begin(), reports.laps.end(), "known_fit"), reports.laps.end());
}

TEST(JobProgressModel, RisesWithinALapAndStopsShortOfDone) {
  const JobProgressModel model;
  EXPECT_DOUBLE_EQ(*model.Progress("loading", 0.0), 0.0);
  EXPECT_LT(*model.Progress("features", 0.2), *model.Progress("features", 0.8));
  EXPECT_LT(*model.Progress("fine_sweep", 1.0), *model.Progress("writing", 0.5));
  EXPECT_LT(*model.Progress("writing", 1.0), 1.0);
  EXPECT_FALSE(model.Progress("no such lap", 0.5));
  EXPECT_EQ(JobProgressModel::StageOf("no such lap"), nullptr);
}

// A device where the tracking takes nearly all of a job's time: after a few
// jobs, half the tracking is about half the job.
TEST(JobProgressModel, LearnsTheSharesOfTheJobsItSees) {
  JobProgressModel model;
  const double before = *model.Progress("features", 0.5);
  const std::vector<std::pair<std::string, double>> laps = {
      {"loading", 10},     {"features", 9000}, {"bundle_adjustment", 300},
      {"fine_sweep", 500}, {"writing", 100},   {"total", 9910}};  // "total" is no lap: not counted
  for (int job = 0; job < 20; ++job) model.Learn(laps);
  const double after = *model.Progress("features", 0.5);
  EXPECT_LT(before, 0.25);
  EXPECT_NEAR(after, (10.0 + 4500.0) / 9910.0, 0.01);
  // A job with no lap the model knows teaches nothing.
  model.Learn({{"total", 50.0}});
  EXPECT_NEAR(*model.Progress("features", 0.5), after, 1e-12);
}

}  // namespace
}  // namespace dfsm::service
