#include "tools/dfsm/video_input.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/videoio.hpp>

#include "core/pipeline/pipeline.h"
#include "core/synth/burst_synthesizer.h"
#include "tools/dfsm/burst_input.h"

namespace dfsm::tools {
namespace {
namespace fs = std::filesystem;

class VideoInputTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { setenv("DFSM_VIDEO_MODULE", DFSM_VIDEO_MODULE_PATH, 1); }
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("dfsm_video_input_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A small burst, and the same frames as a lossless video (FFV1) at 30 fps.
  SynthBurst WriteClip(const fs::path& video, int frames) {
    SynthOptions options;
    options.width = 320;
    options.height = 240;
    options.frames = frames;
    options.supersampling = 1;
    options.rotation_deg = 1.0;
    const SynthBurst burst = SynthesizeBurst(options);
    cv::VideoWriter writer(video.string(), cv::CAP_FFMPEG,
                           cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 30.0,
                           burst.frames.front().size(), true);
    EXPECT_TRUE(writer.isOpened());
    for (const cv::Mat& frame : burst.frames) writer << frame;
    return burst;
  }

  fs::path dir_;
};

// A video gives the frames and the result the same frames in a burst
// directory give.
TEST_F(VideoInputTest, AVideoGivesWhatItsFramesGive) {
  const fs::path video = dir_ / "clip.mkv";
  const SynthBurst synth = WriteClip(video, 10);
  ASSERT_TRUE(IsVideoFile(video.string()));
  const Burst from_video = ReadBurstInput(video.string(), 0, 0);
  const Burst from_frames = ToBurst(synth);
  ASSERT_EQ(from_video.size(), 10);
  EXPECT_EQ(from_video.reference(), 0);
  for (int i = 0; i < 10; ++i)
    EXPECT_EQ(cv::norm(from_video.gray[i], from_frames.gray[i], cv::NORM_INF), 0.0) << i;
  PipelineOptions options;
  options.run_dense = false;
  const PipelineOutput a = RunPipeline(from_video, options);
  const PipelineOutput b = RunPipeline(from_frames, options);
  ASSERT_TRUE(a.result.ok) << a.result.error;
  ASSERT_TRUE(b.result.ok) << b.result.error;
  EXPECT_EQ(a.result.calibration.f, b.result.calibration.f);
  EXPECT_EQ(a.result.calibration.k1, b.result.calibration.k1);
}

// --start and --frames pick frames; --windows cuts the clip.
TEST_F(VideoInputTest, StartFramesAndWindows) {
  const fs::path video = dir_ / "clip.mkv";
  const SynthBurst synth = WriteClip(video, 12);
  const Burst part = ReadBurstInput(video.string(), 4, 5);
  ASSERT_EQ(part.size(), 5);
  EXPECT_EQ(cv::norm(part.gray[0], ToBurst(synth).gray[4], cv::NORM_INF), 0.0);
  EXPECT_EQ(CountVideoFrames(video.string()), 12);
  const std::vector<BurstWindow> windows = WindowsOf(video.string(), 5);
  ASSERT_EQ(windows.size(), 2u);
  EXPECT_EQ(windows[1].start, 5);
  EXPECT_THROW(ReadBurstInput(video.string(), 10, 5), BurstError);
}

// What cannot be read is named, not thrown past the caller.
TEST_F(VideoInputTest, ABrokenVideoIsNamed) {
  const fs::path video = dir_ / "broken.mp4";
  std::ofstream(video) << "not a video";
  try {
    ReadBurstInput(video.string(), 0, 0);
    FAIL() << "a broken video was read";
  } catch (const BurstError& e) {
    EXPECT_NE(std::string(e.what()).find("broken.mp4"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cannot be opened as a video"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(IsVideoFile((dir_ / "absent.mp4").string()));
}

}  // namespace
}  // namespace dfsm::tools
