#include "daemon/service/job_scheduler.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <thread>

namespace dfsm::service {
namespace {

// Work that blocks until released, so tests control what is running.
class Gate {
 public:
  void Wait(const std::string& id) {
    std::unique_lock<std::mutex> lock(mutex_);
    started_.push_back(id);
    changed_.notify_all();
    changed_.wait(lock, [&] { return open_; });
  }
  void Open() {
    std::lock_guard<std::mutex> lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }
  void AwaitStarted(size_t count) {
    std::unique_lock<std::mutex> lock(mutex_);
    ASSERT_TRUE(changed_.wait_for(lock, std::chrono::seconds(10),
                                  [&] { return started_.size() >= count; }));
  }
  std::vector<std::string> started() {
    std::lock_guard<std::mutex> lock(mutex_);
    return started_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = false;
  std::vector<std::string> started_;
};

TEST(JobSchedulerTest, BoundedQueueRefusesWhenFullAndRunsInOrder) {
  Gate gate;
  JobScheduler scheduler(
      1, 2, [&](const std::string& id, std::shared_ptr<const Burst>) { gate.Wait(id); });
  scheduler.Start();
  scheduler.Submit(*scheduler.TryReserve(), "a", nullptr);
  gate.AwaitStarted(1);
  EXPECT_TRUE(scheduler.IsRunning("a"));
  EXPECT_EQ(scheduler.Running(), 1);
  scheduler.Submit(*scheduler.TryReserve(), "b", nullptr);
  {
    auto held = scheduler.TryReserve();  // a reservation counts as queued
    ASSERT_TRUE(held);
    EXPECT_TRUE(scheduler.Full());
    EXPECT_FALSE(scheduler.TryReserve());
  }
  EXPECT_EQ(scheduler.Depth(), 1);  // released when dropped
  scheduler.Submit(*scheduler.TryReserve(), "c", nullptr);
  EXPECT_FALSE(scheduler.TryReserve());
  EXPECT_TRUE(scheduler.RemoveQueued("c"));
  EXPECT_FALSE(scheduler.RemoveQueued("a"));  // running, not queued
  gate.Open();
  gate.AwaitStarted(2);
  scheduler.Shutdown();
  EXPECT_EQ(gate.started(), (std::vector<std::string>{"a", "b"}));
}

TEST(JobSchedulerTest, RecoveredJobsAreNeverRefusedAndShutdownKeepsTheQueue) {
  Gate gate;
  JobScheduler scheduler(
      1, 1, [&](const std::string& id, std::shared_ptr<const Burst>) { gate.Wait(id); });
  for (const char* id : {"r1", "r2", "r3"}) scheduler.SubmitRecovered(id);
  EXPECT_EQ(scheduler.Depth(), 3);
  scheduler.Start();
  gate.AwaitStarted(1);
  std::thread opener([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    gate.Open();
  });
  scheduler.Shutdown();  // waits for r1, starts nothing else
  opener.join();
  EXPECT_EQ(gate.started(), std::vector<std::string>{"r1"});
  EXPECT_EQ(scheduler.Depth(), 2);
  EXPECT_FALSE(scheduler.TryReserve());
}

// A job that never ends while others wait: the queue cannot drain, and the
// watchdog is told so (dfsmd/daemon.h). An idle scheduler is never stalled.
TEST(JobSchedulerTest, AQueueThatCannotDrainIsStalled) {
  Gate gate;
  JobScheduler scheduler(
      1, 4, [&](const std::string& id, std::shared_ptr<const Burst>) { gate.Wait(id); });
  const auto limit = std::chrono::milliseconds(200);
  scheduler.Start();
  std::this_thread::sleep_for(2 * limit);
  EXPECT_FALSE(scheduler.Stalled(limit));  // nothing to do
  scheduler.Submit(*scheduler.TryReserve(), "hung", nullptr);
  scheduler.Submit(*scheduler.TryReserve(), "waiting", nullptr);
  gate.AwaitStarted(1);
  EXPECT_FALSE(scheduler.Stalled(std::chrono::seconds(60)));
  std::this_thread::sleep_for(2 * limit);
  EXPECT_TRUE(scheduler.Stalled(limit));
  gate.Open();
  gate.AwaitStarted(2);
  EXPECT_FALSE(scheduler.Stalled(limit));  // "waiting" just started
  scheduler.Shutdown();
  EXPECT_FALSE(scheduler.Stalled(limit));
}

}  // namespace
}  // namespace dfsm::service
