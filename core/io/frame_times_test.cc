#include "core/io/frame_times.h"

#include <gtest/gtest.h>

namespace dfsm {
namespace {

BurstManifest Frames(const std::vector<int64_t>& sequence, const std::vector<int64_t>& timestamp) {
  BurstManifest manifest;
  for (size_t i = 0; i < sequence.size(); ++i)
    manifest.frames.push_back({"frames/" + std::to_string(i) + ".png", timestamp[i], sequence[i]});
  return manifest;
}

TEST(CaptureTimesTest, ConsecutiveFramesNeedNoTimes) {
  EXPECT_TRUE(CaptureTimes(Frames({7, 8, 9, 10}, {0, 33, 67, 100})).empty());
  // Nothing to go by: every field 0 (or repeated).
  EXPECT_TRUE(CaptureTimes(Frames({0, 0, 0}, {0, 0, 0})).empty());
  EXPECT_EQ(MissingFrames({}), 0);
}

TEST(CaptureTimesTest, ASequenceGapIsADroppedFrame) {
  const std::vector<double> times = CaptureTimes(Frames({10, 11, 12, 14, 15}, {0, 0, 0, 0, 0}));
  EXPECT_EQ(times, (std::vector<double>{0, 1, 2, 4, 5}));
  EXPECT_EQ(MissingFrames(times), 1);
}

// Where the sequence numbers say nothing (consecutive as written by a tool
// that counted what it received), the timestamps do: jitter of a quarter of
// an interval is not a gap, a double interval is.
TEST(CaptureTimesTest, ATimestampGapIsADroppedFrame) {
  const int64_t ms = 1000000;
  const std::vector<double> times =
      CaptureTimes(Frames({0, 1, 2, 3, 4, 5}, {0, 41 * ms, 75 * ms, 108 * ms, 175 * ms, 200 * ms}));
  EXPECT_EQ(times, (std::vector<double>{0, 1, 2, 3, 5, 6}));
  EXPECT_EQ(MissingFrames(times), 1);
  EXPECT_TRUE(CaptureTimes(Frames({0, 1, 2, 3}, {0, 41 * ms, 75 * ms, 100 * ms})).empty());
}

}  // namespace
}  // namespace dfsm
