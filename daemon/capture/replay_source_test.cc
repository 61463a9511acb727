#include "daemon/capture/replay_source.h"

#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/imgcodecs.hpp>

#include "core/io/burst.h"

namespace dfsm::capture {
namespace {

namespace fs = std::filesystem;

// A small gray burst with distinct frames and recorded timestamps 10 ms apart.
fs::path MakeBurst(const fs::path& dir, int frames, int value_base, int64_t step_ns = 10000000) {
  BurstManifest manifest;
  std::vector<cv::Mat> images;
  for (int i = 0; i < frames; ++i) {
    images.push_back(cv::Mat(6, 8, CV_8UC1, cv::Scalar(value_base + i)));
    manifest.frames.push_back({"", i * step_ns, i});
  }
  WriteBurst(dir, manifest, images);
  return dir;
}

class ReplaySourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dfsm_replay_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(ReplaySourceTest, LoopsWithASeamAndKeepsPixels) {
  MakeBurst(dir_, 3, 10);
  ReplaySource source(dir_, -1.0);
  source.Open();
  const SourceDescription d = source.Describe();
  EXPECT_EQ(d.kind, "replay");
  EXPECT_EQ(d.width, 8);
  EXPECT_FALSE(d.color);
  FrameSlot slot;
  std::vector<int> values;
  std::vector<bool> seams;
  for (int i = 0; i < 7; ++i) {
    ASSERT_EQ(source.Read(slot, std::chrono::milliseconds(100)), ReadResult::kFrame);
    values.push_back(slot.gray.at<uint8_t>(0, 0));
    seams.push_back(slot.discontinuity);
    EXPECT_TRUE(slot.color.empty());
  }
  EXPECT_EQ(values, (std::vector<int>{10, 11, 12, 10, 11, 12, 10}));
  EXPECT_EQ(seams, (std::vector<bool>{false, false, false, true, false, false, true}));
}

TEST_F(ReplaySourceTest, ReverseLoopPlaysBackAndForthWithoutASeam) {
  MakeBurst(dir_, 3, 10);
  ReplaySource source(dir_, -1.0, true, ReplayLoop::kReverse);
  source.Open();
  FrameSlot slot;
  std::vector<int> values, sequences;
  for (int i = 0; i < 9; ++i) {
    ASSERT_EQ(source.Read(slot, std::chrono::milliseconds(100)), ReadResult::kFrame);
    values.push_back(slot.gray.at<uint8_t>(0, 0));
    sequences.push_back(static_cast<int>(slot.source_sequence));
    EXPECT_FALSE(slot.discontinuity) << "frame " << i;
  }
  EXPECT_EQ(values, (std::vector<int>{10, 11, 12, 11, 10, 11, 12, 11, 10}));
  EXPECT_EQ(sequences, (std::vector<int>{0, 1, 2, 1, 0, 1, 2, 1, 0}));
}

TEST_F(ReplaySourceTest, ReverseLoopMovesToTheNextBurstWhenBackAtTheFirstFrame) {
  MakeBurst(dir_ / "a", 3, 50);
  MakeBurst(dir_ / "b", 3, 100);
  ReplaySource source(dir_, -1.0, true, ReplayLoop::kReverse);
  source.Open();
  FrameSlot slot;
  std::vector<int> values;
  std::vector<bool> seams;
  for (int i = 0; i < 11; ++i) {
    ASSERT_EQ(source.Read(slot, std::chrono::milliseconds(100)), ReadResult::kFrame);
    values.push_back(slot.gray.at<uint8_t>(0, 0));
    seams.push_back(slot.discontinuity);
  }
  EXPECT_EQ(values, (std::vector<int>{50, 51, 52, 51, 50, 100, 101, 102, 101, 100, 50}));
  EXPECT_EQ(seams, (std::vector<bool>{false, false, false, false, false, true, false, false, false,
                                      false, true}));
}

TEST(ReplayLoop, NamesParseBack) {
  for (ReplayLoop loop : {ReplayLoop::kRestart, ReplayLoop::kReverse})
    EXPECT_EQ(ParseReplayLoop(ReplayLoopName(loop)), loop);
  EXPECT_THROW(ParseReplayLoop("pingpong"), std::invalid_argument);
}

TEST_F(ReplaySourceTest, PacesAtTheRecordedRate) {
  MakeBurst(dir_, 4, 0, 20000000);  // 50 fps
  ReplaySource source(dir_, 0.0);
  const auto opened = std::chrono::steady_clock::now();
  source.Open();
  EXPECT_NEAR(source.Describe().fps, 50.0, 1e-6);
  FrameSlot slot;
  std::vector<int64_t> stamps;
  for (int i = 0; i < 4; ++i) {
    ASSERT_EQ(source.Read(slot, std::chrono::milliseconds(500)), ReadResult::kFrame);
    stamps.push_back(slot.timestamp_ns);
  }
  const auto done = std::chrono::steady_clock::now();
  // The schedule starts at Open() and never runs early, so three intervals
  // have passed when the fourth frame is out, however loaded the machine is.
  // The stamps themselves are wake-up times: a late first wake-up (a loaded
  // sanitizer run) shortens their span, so they are only checked for order
  // and for lying within the reads.
  EXPECT_GE(done - opened, std::chrono::milliseconds(3 * 20));
  // Not paced at some much slower rate (5 fps would take 600 ms).
  EXPECT_LT(done - opened, std::chrono::milliseconds(600));
  for (size_t i = 1; i < stamps.size(); ++i) EXPECT_GT(stamps[i], stamps[i - 1]) << i;
  EXPECT_GE(stamps.front(), MonotonicNs(opened));
  EXPECT_LE(stamps.back(), MonotonicNs(done));
}

TEST_F(ReplaySourceTest, ShortTimeoutBeforeTheNextFrameIsATimeout) {
  MakeBurst(dir_, 3, 0);
  ReplaySource source(dir_, 2.0);  // one frame every 500 ms
  source.Open();
  FrameSlot slot;
  ASSERT_EQ(source.Read(slot, std::chrono::milliseconds(10)), ReadResult::kFrame);
  EXPECT_EQ(source.Read(slot, std::chrono::milliseconds(10)), ReadResult::kTimeout);
}

TEST_F(ReplaySourceTest, PlaysADirectoryOfBurstsInNameOrder) {
  MakeBurst(dir_ / "b", 3, 100);
  MakeBurst(dir_ / "a", 3, 50);
  fs::create_directories(dir_ / "not_a_burst");
  const auto bursts = ReplaySource::FindBursts(dir_);
  ASSERT_EQ(bursts.size(), 2u);
  ReplaySource source(dir_, -1.0);
  source.Open();
  FrameSlot slot;
  std::vector<int> values;
  for (int i = 0; i < 7; ++i) {
    ASSERT_EQ(source.Read(slot, std::chrono::milliseconds(100)), ReadResult::kFrame);
    values.push_back(slot.gray.at<uint8_t>(0, 0));
  }
  EXPECT_EQ(values, (std::vector<int>{50, 51, 52, 100, 101, 102, 50}));
}

TEST_F(ReplaySourceTest, RejectsADirectoryWithoutBursts) {
  fs::create_directories(dir_);
  try {
    ReplaySource::FindBursts(dir_);
    FAIL() << "no exception";
  } catch (const SourceError& e) {
    EXPECT_EQ(e.kind(), SourceError::Kind::kConfig);
    EXPECT_NE(std::string(e.what()).find("manifest.json"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReplaySource::FindBursts(dir_ / "missing"), SourceError);
}

TEST_F(ReplaySourceTest, AMissingFrameFailsOpenWithItsName) {
  MakeBurst(dir_, 3, 0);
  fs::remove(dir_ / "frames/000001.png");
  ReplaySource source(dir_, -1.0);
  try {
    source.Open();
    FAIL() << "no exception";
  } catch (const SourceError& e) {
    EXPECT_NE(std::string(e.what()).find("000001.png"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dfsm::capture
