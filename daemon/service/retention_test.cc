#include "daemon/service/retention.h"

#include <gtest/gtest.h>

namespace dfsm::service {
namespace {

Job MakeJob(int index, JobStatus status, int64_t bytes, int64_t finished_ms) {
  Job job;
  char id[32];
  std::snprintf(id, sizeof(id), "j%013d-0000", 1000 + index);
  job.id = id;
  job.status = status;
  job.created_ms = 1000 + index;
  job.finished_ms = finished_ms;
  job.bytes = bytes;
  return job;
}

TEST(RetentionTest, KeepsTheNewestWithinTheCount) {
  std::vector<Job> jobs;
  for (int i = 0; i < 5; ++i) jobs.push_back(MakeJob(i, JobStatus::kSucceeded, 10, 2000));
  RetentionSection limits;
  limits.max_jobs = 3;
  limits.max_bytes = 0;
  limits.max_age_s = 0;
  const auto expired = SelectExpiredJobs(jobs, limits, 2000);
  ASSERT_EQ(expired.size(), 2u);
  EXPECT_EQ(expired[0], jobs[0].id);  // oldest first
  EXPECT_EQ(expired[1], jobs[1].id);
}

TEST(RetentionTest, BytesAndAgeLimitsAndOlderJobsGoToo) {
  std::vector<Job> jobs = {MakeJob(0, JobStatus::kFailed, 1, 1000),
                           MakeJob(1, JobStatus::kSucceeded, 100, 1000),
                           MakeJob(2, JobStatus::kSucceeded, 60, 1000)};
  RetentionSection limits;
  limits.max_jobs = 0;
  limits.max_bytes = 150;
  limits.max_age_s = 0;
  // 60 fits, 60 + 100 does not: job 1 goes and with it the older job 0.
  EXPECT_EQ(SelectExpiredJobs(jobs, limits, 1000),
            (std::vector<std::string>{jobs[0].id, jobs[1].id}));
  limits.max_bytes = 0;
  limits.max_age_s = 10;
  EXPECT_EQ(SelectExpiredJobs(jobs, limits, 1000 + 10 * 1000).size(), 0u);
  EXPECT_EQ(SelectExpiredJobs(jobs, limits, 1000 + 10 * 1000 + 1).size(), 3u);
}

TEST(RetentionTest, FailedJobsNeverPushResultsOut) {
  // Three results, then a burst of three cheap failing uploads.
  std::vector<Job> jobs;
  for (int i = 0; i < 3; ++i) jobs.push_back(MakeJob(i, JobStatus::kSucceeded, 10, 2000));
  for (int i = 3; i < 6; ++i) jobs.push_back(MakeJob(i, JobStatus::kFailed, 1, 2000));
  RetentionSection limits;
  limits.max_jobs = 4;
  limits.max_bytes = 0;
  limits.max_age_s = 0;
  // The results stay; of the failures only the newest fits.
  EXPECT_EQ(SelectExpiredJobs(jobs, limits, 2000),
            (std::vector<std::string>{jobs[3].id, jobs[4].id}));
}

TEST(RetentionTest, NeverSelectsJobsInFlight) {
  std::vector<Job> jobs = {MakeJob(0, JobStatus::kQueued, 1000, 0),
                           MakeJob(1, JobStatus::kProcessing, 1000, 0),
                           MakeJob(2, JobStatus::kSucceeded, 1000, 1)};
  RetentionSection limits;
  limits.max_jobs = 1;
  limits.max_bytes = 1;
  limits.max_age_s = 1;
  const auto expired = SelectExpiredJobs(jobs, limits, 1'000'000'000);
  EXPECT_EQ(expired, std::vector<std::string>{jobs[2].id});
}

}  // namespace
}  // namespace dfsm::service
