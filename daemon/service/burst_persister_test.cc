#include "daemon/service/burst_persister.h"

#include <gtest/gtest.h>
#include <unistd.h>

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
  EXPECT_EQ(persister.Settle(job.id, true), "");
  EXPECT_EQ(persister.Pending(), 0);
  EXPECT_TRUE(store.Get(job.id)->has_burst);

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
  // Hold the writer on a first burst so the second is still queued when
  // settled: settling the first waits for it, the second is dropped.
  std::vector<std::string> ids;
  for (int i = 0; i < 3; ++i) ids.push_back(store.Create("capture", {}, {}, {}).id);
  BurstPersister persister(&store);
  for (const std::string& id : ids) persister.Enqueue(id, Frames());
  EXPECT_EQ(persister.Settle(ids[2], false), "");
  EXPECT_EQ(persister.Settle(ids[0], true), "");
  EXPECT_EQ(persister.Settle(ids[1], true), "");
  EXPECT_TRUE(store.Get(ids[0])->has_burst);
  EXPECT_TRUE(store.Get(ids[1])->has_burst);
  // ids[2] was dropped unless the writer had already begun it.
  EXPECT_EQ(store.Get(ids[2])->has_burst, fs::exists(store.BurstDir(ids[2])));
  // Settling a job that was never queued returns at once.
  EXPECT_EQ(persister.Settle("j0000000000000-0000", true), "");
}

TEST_F(BurstPersisterTest, QueuedBurstsAreWrittenBeforeItStops) {
  std::vector<std::string> ids;
  {
    JobStore store(dir_);
    for (int i = 0; i < 4; ++i) ids.push_back(store.Create("capture", {}, {}, {}).id);
    BurstPersister persister(&store);
    for (const std::string& id : ids) persister.Enqueue(id, Frames());
  }  // no Settle: the destructor writes them
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
  EXPECT_EQ(persister.Settle(id, true), "");
  EXPECT_FALSE(fs::exists(dir_ / "jobs" / id));
  // Only the store's own staging remains, and it is emptied at the next start.
  JobStore reopened(dir_);
  EXPECT_TRUE(fs::is_empty(dir_ / "tmp"));
}

TEST_F(BurstPersisterTest, AFailedWriteIsReportedOnce) {
  JobStore store(dir_);
  const std::string id = store.Create("capture", {}, {}, {}).id;
  BurstPersister persister(&store);
  CameraBurst broken = Frames();
  broken.frames[3] = cv::Mat(10, 10, CV_8UC3);  // not the size of the others
  persister.Enqueue(id, broken);
  const std::string error = persister.Settle(id, true);
  EXPECT_NE(error.find("cannot store the burst"), std::string::npos) << error;
  EXPECT_NE(error.find("frame 3 differs in size"), std::string::npos) << error;
  EXPECT_FALSE(store.Get(id)->has_burst);
  EXPECT_EQ(persister.Settle(id, true), "");
}

}  // namespace
}  // namespace dfsm::service
