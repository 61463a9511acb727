#include "daemon/service/job_store.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "core/io/file_util.h"

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

class JobStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("job-store-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A staged burst: the store only moves it, so its content is arbitrary.
  fs::path StagedBurst(JobStore* store) {
    const fs::path burst = store->NewStagingDir() / "burst";
    fs::create_directories(burst / "frames");
    WriteFileAtomically(burst / "manifest.json", "{}");
    WriteFileAtomically(burst / "frames" / "000000.png", std::string(100, 'p'));
    return burst;
  }

  fs::path dir_;
};

TEST_F(JobStoreTest, AFinishedJobCountsABurstAttachedWhileItFinished) {
  JobStore store(dir_);
  // A capture's job is created without its burst, which the persister
  // attaches while (or after) the pipeline runs.
  Job job = store.Create("capture", JobOptions{}, fs::path(), {});
  ASSERT_FALSE(job.has_burst);
  // The burst lands after the processor looked at the disk but before its
  // update: the stale count it carries must not stick.
  ASSERT_TRUE(store.AttachBurst(job.id, StagedBurst(&store)));
  job.status = JobStatus::kSucceeded;
  job.bytes = 0;
  store.Update(job);
  EXPECT_GE(store.Get(job.id)->bytes, 102);  // manifest + frame
  // A burst attached after the update is added to the finished job.
  Job other = store.Create("capture", JobOptions{}, fs::path(), {});
  other.status = JobStatus::kSucceeded;
  store.Update(other);
  const int64_t before = store.Get(other.id)->bytes;
  ASSERT_TRUE(store.AttachBurst(other.id, StagedBurst(&store)));
  EXPECT_EQ(store.Get(other.id)->bytes, before + 102);
}

// Ids sort by creation also for jobs created within one millisecond, and a
// reopened store goes on after the newest id it finds.
TEST_F(JobStoreTest, IdsSortByCreationWithinAMillisecond) {
  std::vector<std::string> ids;
  {
    JobStore store(dir_);
    for (int i = 0; i < 50; ++i)
      ids.push_back(store.Create("capture", JobOptions{}, fs::path(), {}).id);
    const std::vector<Job> jobs = store.List();
    ASSERT_EQ(jobs.size(), ids.size());
    for (size_t i = 0; i < ids.size(); ++i) {
      EXPECT_TRUE(IsValidJobId(ids[i])) << ids[i];
      if (i > 0) {
        EXPECT_LT(ids[i - 1], ids[i]);
      }
      EXPECT_EQ(jobs[ids.size() - 1 - i].id, ids[i]);
    }
  }
  JobStore reopened(dir_);
  EXPECT_LT(ids.back(), reopened.Create("capture", JobOptions{}, fs::path(), {}).id);
}

TEST_F(JobStoreTest, CreatesListsNewestFirstAndSurvivesReopening) {
  std::string first, second;
  {
    JobStore store(dir_);
    JobOptions options;
    options.planes = 32;
    first = store.Create("capture", options, StagedBurst(&store), {{"frames", 10}}).id;
    second = store.Create("upload", options, StagedBurst(&store), {}).id;
    EXPECT_TRUE(IsValidJobId(first));
    EXPECT_LT(first, second);
    const std::vector<Job> jobs = store.List();
    ASSERT_EQ(jobs.size(), 2u);
    EXPECT_EQ(jobs[0].id, second);
    Job job = *store.Get(first);
    job.status = JobStatus::kSucceeded;
    job.finished_ms = NowUnixMs();
    job.timings_ms = {{"total", 12.5}};
    store.Update(job);
  }
  JobStore reopened(dir_);
  const std::optional<Job> job = reopened.Get(first);
  ASSERT_TRUE(job);
  EXPECT_EQ(job->status, JobStatus::kSucceeded);
  EXPECT_EQ(job->options.planes, 32);
  EXPECT_EQ(job->input["frames"], 10);
  EXPECT_TRUE(job->has_burst);
  EXPECT_DOUBLE_EQ(job->timings_ms.at(0).second, 12.5);
  EXPECT_TRUE(fs::exists(reopened.BurstDir(first) / "frames" / "000000.png"));
  const std::vector<Job> unfinished = reopened.Unfinished();
  ASSERT_EQ(unfinished.size(), 1u);
  EXPECT_EQ(unfinished[0].id, second);
  EXPECT_EQ(reopened.LatestSucceeded()->id, first);
}

TEST_F(JobStoreTest, StartUpEmptiesStagingAndMovesDamagedJobsAside) {
  std::string id;
  {
    JobStore store(dir_);
    id = store.Create("upload", {}, StagedBurst(&store), {}).id;
    StagedBurst(&store);  // a staged burst never turned into a job
  }
  fs::create_directories(dir_ / "jobs" / "j0000000000001-abcd");
  std::ofstream(dir_ / "jobs" / "j0000000000001-abcd" / "job.json") << "{ not json";
  JobStore reopened(dir_);
  EXPECT_TRUE(fs::is_empty(dir_ / "tmp"));
  EXPECT_TRUE(reopened.Get(id));
  EXPECT_FALSE(reopened.Get("j0000000000001-abcd"));
  EXPECT_TRUE(fs::exists(dir_ / "damaged" / "j0000000000001-abcd" / "job.json"));
}

// A record whose option has a value this daemon does not know (written by
// hand, or by another version) is damaged: moved aside, naming the option and
// its value in the log, while the other jobs load.
TEST_F(JobStoreTest, AStoredJobWithAnUnknownOptionValueIsMovedAside) {
  std::string good, bad;
  {
    JobStore store(dir_);
    JobOptions options;
    options.when = BurstWhen::kNext;
    options.init = InitMode::kNaive;
    good = store.Create("capture", options, StagedBurst(&store), {}).id;
    bad = store.Create("capture", options, StagedBurst(&store), {}).id;
  }
  const fs::path record = dir_ / "jobs" / bad / "job.json";
  std::string text = ReadFileToString(record);
  const size_t at = text.find("\"naive\"");
  ASSERT_NE(at, std::string::npos) << text;
  text.replace(at, 7, "\"rank2\"");
  WriteFileAtomically(record, text);

  JobStore reopened(dir_);
  const std::optional<Job> job = reopened.Get(good);
  ASSERT_TRUE(job);
  EXPECT_EQ(job->options.when, BurstWhen::kNext);
  EXPECT_EQ(job->options.init, InitMode::kNaive);
  EXPECT_FALSE(reopened.Get(bad));
  EXPECT_TRUE(fs::exists(dir_ / "damaged" / bad / "job.json"));
}

TEST_F(JobStoreTest, OutputsReplaceAtomicallyAndRemovalDeletes) {
  JobStore store(dir_);
  const std::string id = store.Create("upload", {}, StagedBurst(&store), {}).id;
  for (const char* content : {"first", "second"}) {
    const fs::path staged = store.NewStagingDir();
    WriteFileAtomically(staged / "result.json", content);
    store.CommitOutput(id, staged);
    EXPECT_EQ(ReadFileToString(store.OutputDir(id) / "result.json"), content);
  }
  EXPECT_GT(JobStore::DirectoryBytes(store.BurstDir(id)), 100);
  store.DropBurst(id);
  EXPECT_FALSE(fs::exists(store.BurstDir(id)));
  EXPECT_TRUE(store.Remove(id));
  EXPECT_FALSE(store.Remove(id));
  EXPECT_FALSE(fs::exists(dir_ / "jobs" / id));
  EXPECT_THROW(store.Update(Job{}), JobStoreError);
}

TEST_F(JobStoreTest, RetentionRemovesOnlyFinishedJobs) {
  JobStore store(dir_);
  std::vector<std::string> ids;
  for (int i = 0; i < 4; ++i) ids.push_back(store.Create("upload", {}, StagedBurst(&store), {}).id);
  for (int i = 0; i < 3; ++i) {
    Job job = *store.Get(ids[i]);
    job.status = JobStatus::kFailed;
    job.finished_ms = NowUnixMs();
    store.Update(job);
  }
  RetentionSection limits;
  limits.max_jobs = 1;
  const std::vector<std::string> removed = store.EnforceRetention(limits, NowUnixMs());
  EXPECT_EQ(removed, (std::vector<std::string>{ids[0], ids[1]}));
  EXPECT_TRUE(store.Get(ids[2]));
  EXPECT_TRUE(store.Get(ids[3]));  // queued: never removed
}

TEST_F(JobStoreTest, UnusableStateDirectoryIsNamed) {
  std::ofstream(dir_.string() + "-file") << "x";
  try {
    JobStore store(dir_.string() + "-file");
    FAIL() << "a file is not a state directory";
  } catch (const JobStoreError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot be created"), std::string::npos);
  }
  fs::remove(dir_.string() + "-file");
}

}  // namespace
}  // namespace dfsm::service
