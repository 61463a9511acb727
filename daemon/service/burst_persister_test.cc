#include "daemon/service/burst_persister.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "core/io/burst.h"

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

class BurstPersisterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("burst-persister-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Five colour frames whose pixels tell them apart.
  static CameraBurst Frames() {
    CameraBurst burst;
    for (int i = 0; i < 5; ++i) {
      cv::Mat frame(24, 32, CV_8UC3);
      cv::randu(frame, cv::Scalar::all(0), cv::Scalar::all(255));
      frame.at<cv::Vec3b>(0, 0) = cv::Vec3b(static_cast<uchar>(i), 0, 0);
      burst.frames.push_back(frame);
    }
    burst.manifest.reference = 2;
    burst.manifest = CompleteManifest(burst.manifest, burst.frames);
    return burst;
  }

  // Waits until every burst queued so far is written (or has failed): the
  // persister's public view of its work.
  static void WaitUntilWritten(const BurstPersister& persister) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (persister.Pending() > 0) {
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "bursts still pending";
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }

  // Staging directories of the store's (JobStore::NewStagingDir) left behind.
  std::vector<std::string> LeftStaging() const {
    std::vector<std::string> left;
    if (!fs::exists(dir_ / "tmp")) return left;
    for (const auto& entry : fs::directory_iterator(dir_ / "tmp")) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("stage-", 0) == 0) left.push_back(name);
    }
    return left;
  }

  fs::path dir_;
};

TEST_F(BurstPersisterTest, StoresTheBurstInItsJobLosslessly) {
  JobStore store(dir_);
  const Job job = store.Create("capture", {}, {}, {});
  EXPECT_FALSE(job.has_burst);
  EXPECT_FALSE(fs::exists(store.BurstDir(job.id)));
  const CameraBurst frames = Frames();
  BurstPersister persister(&store);
  persister.Enqueue(job.id, frames);
  EXPECT_EQ(persister.Pending(), 1);
  WaitUntilWritten(persister);
  EXPECT_TRUE(store.Get(job.id)->has_burst);
  EXPECT_TRUE(LeftStaging().empty());

  const Burst stored = ReadBurst(store.BurstDir(job.id));
  EXPECT_EQ(stored.reference(), 2);
  EXPECT_EQ(stored.manifest.pixel_format, "bgr8");
  ASSERT_EQ(stored.size(), 5);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(cv::norm(stored.gray[i], ToGray8(frames.frames[i]), cv::NORM_INF), 0.0) << i;
  }
  EXPECT_EQ(cv::norm(stored.reference_color, frames.frames[2], cv::NORM_INF), 0.0);
  // The store's has_burst wins over a processor's stale copy of the record.
  Job stale = job;
  stale.status = JobStatus::kProcessing;
  store.Update(stale);
  EXPECT_TRUE(store.Get(job.id)->has_burst);
  EXPECT_TRUE(JobStore(dir_).Get(job.id)->has_burst) << "the record on disk says so too";
}

TEST_F(BurstPersisterTest, ABurstNoLongerNeededIsNotWritten) {
  JobStore store(dir_);
  // The writer is held on the first burst, so the last is still queued when
  // dropped; the others are written.
  std::vector<std::string> ids;
  for (int i = 0; i < 3; ++i) ids.push_back(store.Create("capture", {}, {}, {}).id);
  BurstPersister persister(&store);
  for (const std::string& id : ids) persister.Enqueue(id, Frames());
  persister.Drop(ids[2]);
  WaitUntilWritten(persister);
  EXPECT_TRUE(store.Get(ids[0])->has_burst);
  EXPECT_TRUE(store.Get(ids[1])->has_burst);
  // ids[2] was dropped unless the writer had already begun it.
  EXPECT_EQ(store.Get(ids[2])->has_burst, fs::exists(store.BurstDir(ids[2])));
  EXPECT_TRUE(LeftStaging().empty());
  // Dropping a job that was never queued returns at once.
  persister.Drop("j0000000000000-0000");
}

// Drop() leaves nothing of the job's burst in flight: a queued one is gone
// and one being written has been attached (or not) before it returns.
TEST_F(BurstPersisterTest, AfterDropNothingOfTheBurstIsPending) {
  JobStore store(dir_);
  std::vector<std::string> ids;
  for (int i = 0; i < 3; ++i) ids.push_back(store.Create("capture", {}, {}, {}).id);
  BurstPersister persister(&store);
  for (const std::string& id : ids) persister.Enqueue(id, Frames());
  for (const std::string& id : ids) persister.Drop(id);
  EXPECT_EQ(persister.Pending(), 0);
  for (const std::string& id : ids) {
    const bool attached = store.Get(id)->has_burst;
    EXPECT_EQ(attached, fs::exists(store.BurstDir(id))) << id;
    if (attached) {
      EXPECT_EQ(ReadBurst(store.BurstDir(id)).size(), 5) << id;
    }
  }
  EXPECT_TRUE(LeftStaging().empty());
}

TEST_F(BurstPersisterTest, QueuedBurstsAreWrittenBeforeItStops) {
  std::vector<std::string> ids;
  {
    JobStore store(dir_);
    for (int i = 0; i < 4; ++i) ids.push_back(store.Create("capture", {}, {}, {}).id);
    BurstPersister persister(&store);
    for (const std::string& id : ids) persister.Enqueue(id, Frames());
  }  // not waited for: the destructor writes them
  JobStore reopened(dir_);
  for (const std::string& id : ids) {
    EXPECT_TRUE(reopened.Get(id)->has_burst) << id;
    EXPECT_EQ(ReadBurst(reopened.BurstDir(id)).size(), 5);
  }
}

TEST_F(BurstPersisterTest, AJobDeletedWhileItsBurstIsWrittenLeavesNothing) {
  JobStore store(dir_);
  const std::string id = store.Create("capture", {}, {}, {}).id;
  BurstPersister persister(&store);
  ASSERT_TRUE(store.Remove(id));
  persister.Enqueue(id, Frames());
  WaitUntilWritten(persister);
  EXPECT_FALSE(fs::exists(dir_ / "jobs" / id));
  EXPECT_TRUE(LeftStaging().empty());
  // Only the store's own staging remains, and it is emptied at the next start.
  JobStore reopened(dir_);
  EXPECT_TRUE(fs::is_empty(dir_ / "tmp"));
}

// A write that fails is logged, naming the job and the cause; the job keeps
// no burst and the half-written one is removed with its staging directory.
TEST_F(BurstPersisterTest, AFailedWriteIsLoggedAndLeavesTheJobWithoutABurst) {
  JobStore store(dir_);
  const std::string id = store.Create("capture", {}, {}, {}).id;
  CameraBurst broken = Frames();
  broken.frames[3] = cv::Mat(10, 10, CV_8UC3);  // not the size of the others
  ::testing::internal::CaptureStderr();
  {
    BurstPersister persister(&store);
    persister.Enqueue(id, broken);
    WaitUntilWritten(persister);
  }
  const std::string log = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(log.find("job " + id + ": cannot store the burst"), std::string::npos) << log;
  EXPECT_NE(log.find("frame 3 differs in size"), std::string::npos) << log;
  EXPECT_EQ(log.find(dir_.string()), std::string::npos) << "the state directory is hidden: " << log;
  const Job job = *store.Get(id);
  EXPECT_FALSE(job.has_burst);
  EXPECT_EQ(job.status, JobStatus::kQueued);  // the job runs on the frames in memory
  EXPECT_FALSE(fs::exists(store.BurstDir(id)));
  EXPECT_TRUE(LeftStaging().empty());
}

}  // namespace
}  // namespace dfsm::service
