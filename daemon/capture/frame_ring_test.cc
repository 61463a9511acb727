#include "daemon/capture/frame_ring.h"

#include <gtest/gtest.h>

#include <thread>

namespace dfsm::capture {
namespace {

using Clock = std::chrono::steady_clock;

void Write(FrameRing& ring, int64_t sequence, uint8_t value) {
  FrameSlot* slot = ring.Staging();
  ASSERT_NE(slot, nullptr);
  slot->gray.create(4, 6, CV_8UC1);
  slot->gray.setTo(value);
  slot->timestamp_ns = sequence * 1000;
  slot->source_sequence = sequence + 100;
  ring.Publish(sequence);
}

TEST(FrameRing, KeepsTheNewestCapacityFramesInOrder) {
  FrameRing ring(3);
  for (int i = 0; i < 5; ++i) Write(ring, i, static_cast<uint8_t>(i));
  EXPECT_EQ(ring.Fill(), 3);
  EXPECT_EQ(*ring.NewestSequence(), 4);
  EXPECT_EQ(*ring.NewestRunStart(), 2);
  const auto oldest = ring.CopyAtOrAfter(0, Clock::now(), nullptr);
  ASSERT_TRUE(oldest);
  EXPECT_EQ(oldest->sequence, 2);  // 0 and 1 were overwritten: the caller sees the gap
  EXPECT_EQ(oldest->gray.at<uint8_t>(0, 0), 2);
  EXPECT_EQ(oldest->source_sequence, 102);
  EXPECT_EQ(oldest->timestamp_ns, 2000);
}

TEST(FrameRing, RunStartStopsAtAGap) {
  FrameRing ring(8);
  Write(ring, 0, 0);
  Write(ring, 1, 1);
  Write(ring, 5, 5);
  Write(ring, 6, 6);
  EXPECT_EQ(*ring.NewestRunStart(), 5);
}

TEST(FrameRing, NoAllocationOnceBuffersExist) {
  FrameRing ring(4);
  ring.Preallocate(6, 4, false);
  std::vector<const uint8_t*> seen;
  for (int i = 0; i < 20; ++i) {
    FrameSlot* slot = ring.Staging();
    ASSERT_NE(slot, nullptr);
    slot->gray.create(4, 6, CV_8UC1);  // same size: reuses the buffer
    seen.push_back(slot->gray.data);
    ring.Publish(i);
  }
  std::sort(seen.begin(), seen.end());
  seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
  EXPECT_EQ(seen.size(), 5u);  // capacity + one staging buffer, cycled
}

TEST(FrameRing, ReaderWaitsForTheNextFrame) {
  FrameRing ring(4);
  Write(ring, 0, 0);
  std::thread writer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    Write(ring, 1, 7);
  });
  const auto frame = ring.CopyAtOrAfter(1, Clock::now() + std::chrono::seconds(5), nullptr);
  writer.join();
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->sequence, 1);
  EXPECT_EQ(frame->gray.at<uint8_t>(0, 0), 7);
}

TEST(FrameRing, ABurstCopyTakesTheColourImageAloneTheNewestFrameBoth) {
  FrameRing ring(2);
  FrameSlot* slot = ring.Staging();
  slot->gray.create(4, 6, CV_8UC1);
  slot->gray.setTo(9);
  slot->color.create(4, 6, CV_8UC3);
  slot->color.setTo(cv::Scalar(1, 2, 3));
  ring.Publish(0);
  const auto burst_frame = ring.CopyAtOrAfter(0, Clock::now(), nullptr);
  ASSERT_TRUE(burst_frame);
  EXPECT_TRUE(burst_frame->gray.empty());
  EXPECT_EQ(burst_frame->color.at<cv::Vec3b>(3, 5), cv::Vec3b(1, 2, 3));
  const auto newest = ring.CopyNewest();
  ASSERT_TRUE(newest);
  EXPECT_EQ(newest->gray.at<uint8_t>(3, 5), 9);
  EXPECT_EQ(newest->color.at<cv::Vec3b>(3, 5), cv::Vec3b(1, 2, 3));
}

TEST(FrameRing, ReaderTimesOutAndAborts) {
  FrameRing ring(4);
  EXPECT_FALSE(ring.CopyAtOrAfter(0, Clock::now() + std::chrono::milliseconds(10), nullptr));
  EXPECT_FALSE(ring.CopyAtOrAfter(0, Clock::now() + std::chrono::seconds(10), [] { return true; }));
  EXPECT_FALSE(ring.CopyNewest());
}

TEST(FrameRing, PreallocateWithANewSizeForgetsOldFrames) {
  FrameRing ring(4);
  ring.Preallocate(6, 4, false);
  Write(ring, 0, 1);
  ring.Preallocate(6, 4, false);  // same size: kept
  EXPECT_EQ(ring.Fill(), 1);
  ring.Preallocate(8, 8, true);
  EXPECT_EQ(ring.Fill(), 0);
  FrameSlot* slot = ring.Staging();
  ASSERT_NE(slot, nullptr);
  EXPECT_EQ(slot->color.cols, 8);
}

TEST(FrameRing, ConcurrentReadersNeverSeeATornFrame) {
  FrameRing ring(4, 2);
  ring.Preallocate(64, 64, false);
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int i = 0; i < 3000; ++i) {
      FrameSlot* slot = ring.Staging();
      if (slot == nullptr) continue;  // readers hold every spare: drop
      slot->gray.create(64, 64, CV_8UC1);
      slot->gray.setTo(static_cast<uint8_t>(i & 0xff));
      ring.Publish(i);
    }
    done = true;
  });
  std::vector<std::thread> readers;
  std::atomic<int> copies{0};
  for (int r = 0; r < 3; ++r)
    readers.emplace_back([&] {
      while (!done) {
        const auto frame = ring.CopyNewest();
        if (!frame) continue;
        double lo, hi;
        cv::minMaxLoc(frame->gray, &lo, &hi);
        ASSERT_EQ(lo, hi) << "frame " << frame->sequence << " was overwritten while copied";
        ASSERT_EQ(static_cast<int>(lo), static_cast<int>(frame->sequence & 0xff));
        ++copies;
      }
    });
  writer.join();
  for (auto& reader : readers) reader.join();
  EXPECT_GT(copies.load(), 0);
}

}  // namespace
}  // namespace dfsm::capture
