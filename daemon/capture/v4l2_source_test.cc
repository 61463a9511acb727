#include "daemon/capture/v4l2_source.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "daemon/capture/fake_v4l2_device.h"
#include "daemon/capture/streaming_service.h"

namespace dfsm::capture {
namespace {

using std::chrono::milliseconds;

// The fake driver's pattern at (x, y) of the frame with driver sequence s.
uint8_t Pattern(int x, int y, uint32_t s) {
  return static_cast<uint8_t>((x + 2 * y + 3 * s) & 0xff);
}

::testing::AssertionResult HasPattern(const cv::Mat& gray, uint32_t sequence) {
  for (int y = 0; y < gray.rows; y += 7)
    for (int x = 0; x < gray.cols; x += 5)
      if (gray.at<uint8_t>(y, x) != Pattern(x, y, sequence))
        return ::testing::AssertionFailure()
               << "pixel (" << x << ", " << y << ") is " << int(gray.at<uint8_t>(y, x))
               << ", expected " << int(Pattern(x, y, sequence));
  return ::testing::AssertionSuccess();
}

class V4l2SourceTest : public ::testing::Test {
 protected:
  std::unique_ptr<V4l2Source> MakeSource(V4l2Source::Options options = {}) {
    if (options.path.empty()) options.path = "/dev/video-fake";
    options.by_id_dir = "/nonexistent";
    return std::make_unique<V4l2Source>(options, MakeFakeV4l2Device(driver_));
  }
  ReadResult Read(V4l2Source& source) { return source.Read(slot_, milliseconds(50)); }

  std::shared_ptr<FakeV4l2Driver> driver_ = std::make_shared<FakeV4l2Driver>();
  FrameSlot slot_;
};

TEST_F(V4l2SourceTest, NegotiatesTheDriversAnswerAndStreams) {
  V4l2Source::Options options;
  options.width = 1000;  // more than the driver has: it answers 640x480
  options.height = 900;
  options.fps = 60;  // more than it has: 30
  auto source = MakeSource(options);
  source->Open();
  const SourceDescription d = source->Describe();
  EXPECT_EQ(d.format, "YUYV");
  EXPECT_EQ(d.width, 640);
  EXPECT_EQ(d.height, 480);
  EXPECT_DOUBLE_EQ(d.fps, 30.0);
  EXPECT_EQ(d.driver, "fake");
  EXPECT_TRUE(d.color);
  EXPECT_EQ(d.details["buffers"], 4);
  EXPECT_EQ(driver_->mapped, 4);
  for (uint32_t s = 0; s < 3; ++s) {
    ASSERT_EQ(Read(*source), ReadResult::kFrame);
    EXPECT_EQ(slot_.source_sequence, s);
    EXPECT_TRUE(HasPattern(slot_.gray, s));
    EXPECT_EQ(slot_.color.type(), CV_8UC3);
    EXPECT_EQ(slot_.timestamp_ns, 1000000000 + static_cast<int64_t>(s) * 33333333 / 1000 * 1000);
  }
  EXPECT_EQ(driver_->max_outstanding, 1);  // every buffer went straight back
  source->Close();
  EXPECT_EQ(driver_->mapped, 0);
  EXPECT_EQ(driver_->open_fds, 0);
}

TEST_F(V4l2SourceTest, OddBytesPerLineNv12AndGrey) {
  driver_->row_padding = 13;
  for (const char* fourcc : {"NV12", "GREY", "YUYV"}) {
    V4l2Source::Options options;
    options.fourcc = fourcc;
    auto source = MakeSource(options);
    source->Open();
    EXPECT_EQ(source->Describe().format, fourcc);
    EXPECT_EQ(source->Describe().details["bytesperline"],
              (std::string(fourcc) == "YUYV" ? 1280 : 640) + 13);
    ASSERT_EQ(Read(*source), ReadResult::kFrame) << fourcc;
    EXPECT_TRUE(HasPattern(slot_.gray, slot_.source_sequence)) << fourcc;
    EXPECT_EQ(slot_.color.empty(), std::string(fourcc) == "GREY");
  }
}

TEST_F(V4l2SourceTest, RemembersTheStableByIdNameOfItsNode) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("dfsm_byid_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "by-id");
  std::ofstream(dir / "video7").put('x');  // stands in for the device node
  fs::create_symlink(dir / "video7", dir / "by-id" / "usb-Cam_123-video-index0");
  V4l2Source::Options options;
  options.path = (dir / "video7").string();
  options.by_id_dir = (dir / "by-id").string();
  V4l2Source source(options, MakeFakeV4l2Device(driver_));
  source.Open();
  EXPECT_EQ(source.Describe().details["stable_path"],
            (dir / "by-id" / "usb-Cam_123-video-index0").string());
  source.Close();
  source.Open();  // reopens through the stable name
  EXPECT_EQ(source.Describe().device, (dir / "by-id" / "usb-Cam_123-video-index0").string());
  source.Close();
  fs::remove_all(dir);
}

TEST_F(V4l2SourceTest, TooSlowUncompressedFallsBackToMjpegOnlyWhenFaster) {
  driver_->formats = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_MJPEG};
  V4l2Source::Options options;
  options.fps = 60;  // the fake reaches 30 in every format: YUYV stays
  auto source = MakeSource(options);
  source->Open();
  EXPECT_EQ(source->Describe().format, "YUYV");
  EXPECT_DOUBLE_EQ(source->Describe().fps, 30.0);
}

TEST_F(V4l2SourceTest, AFormatTheDriverLacksIsAConfigError) {
  V4l2Source::Options options;
  options.fourcc = "MJPG";
  auto source = MakeSource(options);
  try {
    source->Open();
    FAIL() << "no exception";
  } catch (const SourceError& e) {
    EXPECT_EQ(e.kind(), SourceError::Kind::kConfig);
    EXPECT_NE(std::string(e.what()).find("does not offer MJPG (offers YUYV, NV12, GREY)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(driver_->open_fds, 0);  // a failed open leaves nothing open
}

TEST_F(V4l2SourceTest, EagainAndTimeoutsAreNotErrors) {
  auto source = MakeSource();
  source->Open();
  driver_->faults = {FakeFault::kEagain};
  ASSERT_EQ(Read(*source), ReadResult::kFrame);  // after the EAGAIN
  EXPECT_EQ(slot_.dropped_before, 0u);
  driver_->faults = {FakeFault::kTimeout};
  EXPECT_EQ(Read(*source), ReadResult::kTimeout);
  ASSERT_EQ(Read(*source), ReadResult::kFrame);
  EXPECT_EQ(slot_.source_sequence, 1u);
}

TEST_F(V4l2SourceTest, ErrorFlagAndSequenceGapsCountAsDrops) {
  auto source = MakeSource();
  source->Open();
  ASSERT_EQ(Read(*source), ReadResult::kFrame);
  driver_->faults = {FakeFault::kErrorFlag, FakeFault::kSkip2};
  ASSERT_EQ(Read(*source), ReadResult::kFrame);
  // Sequence 1 was flagged (1 drop), then 2 and 3 were lost (2 drops).
  EXPECT_EQ(slot_.source_sequence, 4u);
  EXPECT_EQ(slot_.dropped_before, 3u);
  EXPECT_TRUE(HasPattern(slot_.gray, 4));
  EXPECT_EQ(driver_->max_outstanding, 1);
}

TEST_F(V4l2SourceTest, EioRestartsTheStreamInPlace) {
  auto source = MakeSource();
  source->Open();
  ASSERT_EQ(Read(*source), ReadResult::kFrame);
  driver_->faults = {FakeFault::kEio};
  ASSERT_EQ(Read(*source), ReadResult::kFrame);
  EXPECT_EQ(source->stream_restarts(), 1);
  EXPECT_EQ(driver_->streamons, 2);
  EXPECT_TRUE(slot_.discontinuity);
  EXPECT_EQ(driver_->mapped, 4);
}

TEST_F(V4l2SourceTest, QbufEioAfterAFatalErrorRestartsTheStream) {
  auto source = MakeSource();
  source->Open();
  ASSERT_EQ(Read(*source), ReadResult::kFrame);
  driver_->faults = {FakeFault::kFatalAfter};
  ASSERT_EQ(Read(*source), ReadResult::kFrame);  // delivered before the queue failed
  EXPECT_TRUE(HasPattern(slot_.gray, 1));
  EXPECT_FALSE(slot_.discontinuity);
  EXPECT_EQ(source->stream_restarts(), 1);
  ASSERT_EQ(Read(*source), ReadResult::kFrame);
  EXPECT_TRUE(slot_.discontinuity);  // the stream restarted in between
  EXPECT_EQ(driver_->streamons, 2);
}

TEST_F(V4l2SourceTest, UnplugIsGoneUntilTheDeviceReturns) {
  auto source = MakeSource();
  source->Open();
  ASSERT_EQ(Read(*source), ReadResult::kFrame);
  driver_->faults = {FakeFault::kUnplug};
  try {
    Read(*source);
    FAIL() << "no exception";
  } catch (const SourceError& e) {
    EXPECT_EQ(e.kind(), SourceError::Kind::kGone);
    EXPECT_NE(std::string(e.what()).find("/dev/video-fake: VIDIOC_DQBUF failed, device gone"),
              std::string::npos)
        << e.what();
  }
  source->Close();
  EXPECT_EQ(driver_->open_fds, 0);
  for (int attempt = 0; attempt < 2; ++attempt) {
    try {
      source->Open();
      FAIL() << "opened an absent device";
    } catch (const SourceError& e) {
      EXPECT_EQ(e.kind(), SourceError::Kind::kGone);
      EXPECT_NE(std::string(e.what()).find("no such device"), std::string::npos) << e.what();
    }
  }
  source->Open();  // back
  ASSERT_EQ(Read(*source), ReadResult::kFrame);
}

TEST_F(V4l2SourceTest, FormatChangedUnderUsIsDetected) {
  for (FakeFault fault : {FakeFault::kFormatChange, FakeFault::kSourceChange}) {
    driver_ = std::make_shared<FakeV4l2Driver>();
    auto source = MakeSource();
    source->Open();
    ASSERT_EQ(Read(*source), ReadResult::kFrame);
    driver_->faults = {fault};
    try {
      Read(*source);
      FAIL() << "no exception";
    } catch (const SourceError& e) {
      EXPECT_EQ(e.kind(), SourceError::Kind::kIo);
      EXPECT_NE(std::string(e.what()).find("renegotiating"), std::string::npos) << e.what();
    }
    source->Close();
    source->Open();  // negotiates the new size
    EXPECT_EQ(source->Describe().width, 320);
    ASSERT_EQ(Read(*source), ReadResult::kFrame);
    EXPECT_EQ(slot_.gray.cols, 320);
  }
}

TEST_F(V4l2SourceTest, ServiceRecoversFromAnUnplugAndNeverBridgesTheGap) {
  CaptureConfig config;
  config.source = "v4l2:/dev/video-fake";
  config.ring_frames = 256;  // the fake driver is unpaced: slack for slow (sanitized) readers
  config.reconnect_backoff = milliseconds(5);
  V4l2Source::Options options;
  options.path = "/dev/video-fake";
  options.by_id_dir = "/nonexistent";
  StreamingCaptureService service(
      config, std::make_unique<V4l2Source>(options, MakeFakeV4l2Device(driver_)));
  service.Start();
  // The 5 s below are for frames, not for filling the 257 x VGA ring, which
  // took over 10 s under ThreadSanitizer on a loaded host (with the ring lock
  // held, so the grab could not even notice its deadline).
  const auto streaming_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!service.Status().streaming && std::chrono::steady_clock::now() < streaming_deadline)
    std::this_thread::sleep_for(milliseconds(2));
  const auto burst = service.GrabBurst(5, BurstWhen::kNext, milliseconds(5000));
  EXPECT_EQ(burst.manifest.source["driver"], "fake");
  EXPECT_EQ(burst.manifest.source["format"], "YUYV");
  {
    std::lock_guard<std::mutex> lock(driver_->mutex);
    driver_->faults = {FakeFault::kSkip2, FakeFault::kUnplug};
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (service.Status().reconnects < 1 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(milliseconds(2));
  const CaptureStatus status = service.Status();
  EXPECT_EQ(status.reconnects, 1u);
  EXPECT_GE(status.frames_dropped, 2u);
  const auto after = service.GrabBurst(5, BurstWhen::kNext, milliseconds(5000));
  for (size_t i = 1; i < after.manifest.frames.size(); ++i)
    EXPECT_EQ(after.manifest.frames[i].sequence, after.manifest.frames[i - 1].sequence + 1);
  service.Stop();
  EXPECT_EQ(driver_->open_fds, 0);
}

}  // namespace
}  // namespace dfsm::capture
