#include "daemon/capture/capture_service.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "daemon/capture/streaming_service.h"

namespace dfsm::capture {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;

const fs::path kFlower = fs::path(DFSM_SHARED_DIR) / "data" / "flower";

// Skips the test where the shared flower clip is absent (a checkout without
// ../shared): every replay test here reads it.
#define SKIP_WITHOUT_FLOWER()                                                              \
  if (!fs::is_directory(kFlower))                                                          \
  GTEST_SKIP() << kFlower.string()                                                         \
               << " is absent (the shared data lives in ../shared beside the repository; " \
                  "see its README)"

fs::path TempDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("dfsm_capture_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  return dir;
}

template <typename Predicate>
bool WaitFor(Predicate predicate, milliseconds limit = milliseconds(5000)) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (predicate()) return true;
    std::this_thread::sleep_for(milliseconds(2));
  }
  return predicate();
}

std::string ConfigError(const CaptureConfig& config) {
  try {
    CaptureService::Create(config);
  } catch (const CaptureConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(CaptureServiceCreate, RejectsConfigurationsThatCanNeverWork) {
  CaptureConfig config;
  config.source = "webcam0";
  EXPECT_NE(ConfigError(config).find("no scheme"), std::string::npos);
  config.source = "gopro:1";
  EXPECT_NE(ConfigError(config).find("unknown scheme \"gopro\""), std::string::npos);
  config.source = "replay:/nonexistent/dfsm";
  EXPECT_NE(ConfigError(config).find("/nonexistent/dfsm"), std::string::npos);
  SKIP_WITHOUT_FLOWER();
  config.source = "replay:" + kFlower.string();
  config.ring_frames = 1;
  EXPECT_NE(ConfigError(config).find("ring_frames"), std::string::npos);
  config.ring_frames = 64;
  config.device_buffers = 2;
  EXPECT_NE(ConfigError(config).find("device_buffers"), std::string::npos);
  config.device_buffers = 4;
  config.width = 640;
  EXPECT_NE(ConfigError(config).find("width and height"), std::string::npos);
  config.width = 0;
  config.source = "v4l2:/dev/video0";
  config.fps = -1;
  EXPECT_NE(ConfigError(config).find("only a replay"), std::string::npos);
}

CaptureConfig FlowerReplay(double fps) {
  CaptureConfig config;
  config.source = "replay:" + kFlower.string();
  config.fps = fps;
  config.ring_frames = 40;
  return config;
}

TEST(CaptureServiceReplay, RecordedBurstIsBitExactWithTheOriginal) {
  SKIP_WITHOUT_FLOWER();
  // A camera's rate: at 100 fps a reader slowed down by ThreadSanitizer on a
  // loaded 2-core host was lapped in the 40-frame ring (149 gaps in 10 s).
  auto service = CaptureService::Create(FlowerReplay(30.0));
  service->Start();
  // 31 frames of a 31-frame loop: the grab restarts at the loop's seam, so it
  // returns the recorded burst exactly once, in order.
  CaptureService::Burst burst = service->GrabBurst(31, BurstWhen::kNext, milliseconds(10000));
  service->Stop();

  ASSERT_EQ(burst.frames.size(), 31u);
  EXPECT_EQ(burst.manifest.pixel_format, "bgr8");
  EXPECT_EQ(burst.manifest.source["kind"], "replay");
  EXPECT_EQ(burst.manifest.source["source_sequence_first"], 0);
  EXPECT_EQ(burst.manifest.source["source_sequence_last"], 30);
  for (size_t i = 1; i < burst.manifest.frames.size(); ++i) {
    EXPECT_EQ(burst.manifest.frames[i].sequence, burst.manifest.frames[i - 1].sequence + 1);
    EXPECT_GT(burst.manifest.frames[i].timestamp_ns, burst.manifest.frames[i - 1].timestamp_ns);
  }

  const fs::path out = TempDir("recorded");
  WriteBurst(out, burst.manifest, burst.frames);
  const BurstManifest original = ReadBurstManifest(kFlower);
  const BurstManifest recorded = ReadBurstManifest(out);
  ASSERT_EQ(recorded.frames.size(), original.frames.size());
  EXPECT_EQ(recorded.source["uri"], "replay:" + kFlower.string());
  for (size_t i = 0; i < original.frames.size(); ++i) {
    const cv::Mat a =
        cv::imread((kFlower / original.frames[i].file).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat b = cv::imread((out / recorded.frames[i].file).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_EQ(a.type(), b.type());
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << "frame " << i << " differs";
  }
  fs::remove_all(out);
}

TEST(CaptureServiceReplay, LastBurstStatusAndIncreasingSequences) {
  SKIP_WITHOUT_FLOWER();
  auto service = CaptureService::Create(FlowerReplay(500.0));
  service->Start();
  // 70 PNG decodes: seconds under a sanitizer beside other tests. The wait is
  // for the frames, not a measure of their speed.
  ASSERT_TRUE(
      WaitFor([&] { return service->Status().frames_captured >= 70; }, milliseconds(60000)));
  const CaptureStatus status = service->Status();
  EXPECT_TRUE(status.streaming);
  EXPECT_EQ(status.width, 512);
  EXPECT_EQ(status.height, 288);
  EXPECT_EQ(status.format, "png");
  EXPECT_EQ(status.driver, "replay");
  EXPECT_EQ(status.frames_dropped, 0u);  // a seam is no loss
  EXPECT_EQ(status.ring_capacity, 40);
  EXPECT_EQ(status.ring_fill, 40);
  EXPECT_TRUE(status.last_error.empty());
  EXPECT_GT(status.last_frame_monotonic_ns, 0);

  CaptureService::Burst burst = service->GrabBurst(5, BurstWhen::kLast, milliseconds(5000));
  ASSERT_EQ(burst.frames.size(), 5u);
  const int64_t first = burst.manifest.source["source_sequence_first"];
  EXPECT_EQ(burst.manifest.source["source_sequence_last"], first + 4);
  EXPECT_GE(burst.manifest.frames[0].sequence, 60);  // kept increasing across loops

  const auto latest = service->LatestFrame();
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->gray.type(), CV_8UC1);
  EXPECT_EQ(latest->color.type(), CV_8UC3);
  EXPECT_GE(latest->sequence, burst.manifest.frames.back().sequence);
  service->Stop();
  service->Stop();  // idempotent
  EXPECT_FALSE(service->Status().streaming);
}

TEST(CaptureServiceReplay, TimeoutAndOversizedBurstsAreUnavailable) {
  SKIP_WITHOUT_FLOWER();
  auto service = CaptureService::Create(FlowerReplay(20.0));
  EXPECT_THROW(service->GrabBurst(5, BurstWhen::kNext, milliseconds(10)), CaptureUnavailable);
  service->Start();
  try {
    service->GrabBurst(30, BurstWhen::kNext, milliseconds(100));
    FAIL() << "no exception";
  } catch (const CaptureUnavailable& e) {
    EXPECT_NE(std::string(e.what()).find("timed out"), std::string::npos) << e.what();
  }
  EXPECT_THROW(service->GrabBurst(41, BurstWhen::kLast, milliseconds(10)), CaptureUnavailable);
}

// A source that plays a script of frames with given losses, then fails in a
// given way: the error paths of the service without a device.
class ScriptedSource : public FrameSource {
 public:
  struct Step {
    uint64_t dropped_before = 0;
    bool fail_gone = false;
    bool restarted = false;  // the stream restarted in place before this frame
  };
  explicit ScriptedSource(std::vector<Step> steps) : steps_(std::move(steps)) {}
  void Open() override {
    if (next_ >= steps_.size()) throw SourceError(SourceError::Kind::kGone, "scripted: gone");
    ++opens_;
  }
  void Close() override {}
  ReadResult Read(FrameSlot& slot, milliseconds timeout) override {
    if (next_ >= steps_.size()) {
      std::this_thread::sleep_for(timeout);
      return ReadResult::kTimeout;
    }
    const Step step = steps_[next_++];
    if (step.fail_gone) throw SourceError(SourceError::Kind::kGone, "scripted: device unplugged");
    slot.gray.create(2, 2, CV_8UC1);
    slot.gray.setTo(static_cast<uint8_t>(next_));
    slot.color.release();
    slot.timestamp_ns = static_cast<int64_t>(next_) * 1000;
    slot.source_sequence = static_cast<int64_t>(next_);
    slot.dropped_before = step.dropped_before;
    slot.discontinuity = step.restarted;
    restarts_ += step.restarted;
    std::this_thread::sleep_for(milliseconds(1));
    return ReadResult::kFrame;
  }
  SourceDescription Describe() const override {
    SourceDescription d;
    d.kind = "scripted";
    d.width = d.height = 2;
    d.details = {{"stream_restarts", restarts_}};
    return d;
  }
  int opens_ = 0;

 private:
  std::vector<Step> steps_;
  size_t next_ = 0;
  int restarts_ = 0;
};

CaptureConfig SmallConfig() {
  CaptureConfig config;
  config.source = "scripted:";
  config.ring_frames = 16;
  config.reconnect_backoff = milliseconds(5);
  config.frame_timeout = milliseconds(200);
  return config;
}

TEST(CaptureServiceReplay, UnpacedReplayWaitsForTheBurstReader) {
  // A recording loses nothing by waiting: unpaced into a ring exactly the
  // burst's size, the writer would lap any reader, so it must wait for it.
  // Before it did, the VM suite timed out here after 1078 restarts.
  SKIP_WITHOUT_FLOWER();
  CaptureConfig config = FlowerReplay(-1.0);
  config.ring_frames = 31;
  auto service = CaptureService::Create(config);
  service->Start();
  for (int round = 0; round < 3; ++round) {
    const CaptureService::Burst burst =
        service->GrabBurst(31, BurstWhen::kNext, milliseconds(20000));
    ASSERT_EQ(burst.frames.size(), 31u);
    EXPECT_EQ(burst.manifest.source["source_sequence_first"], 0);
    EXPECT_EQ(burst.manifest.source["source_sequence_last"], 30);
  }
  // And it runs on once the reader is gone.
  const uint64_t before = service->Status().frames_captured;
  EXPECT_TRUE(WaitFor([&] { return service->Status().frames_captured > before + 100; }));
  service->Stop();
}

// A live source as fast as the machine: nothing waits for a slow reader.
class FloodSource : public FrameSource {
 public:
  void Open() override {}
  void Close() override {}
  ReadResult Read(FrameSlot& slot, milliseconds) override {
    slot.gray.create(480, 640, CV_8UC1);
    slot.gray.setTo(static_cast<uint8_t>(next_));
    slot.color.release();
    slot.timestamp_ns = next_ * 1000;
    slot.source_sequence = next_++;
    slot.dropped_before = 0;
    slot.discontinuity = false;
    return ReadResult::kFrame;
  }
  SourceDescription Describe() const override {
    SourceDescription d;
    d.kind = "flood";
    d.width = 640;
    d.height = 480;
    return d;
  }

 private:
  int64_t next_ = 0;
};

TEST(CaptureServiceGaps, AReaderSlowerThanALiveWriterEndsAtItsDeadline) {
  // Into a 3-frame ring the copies may never keep up, every attempt may meet
  // a gap, and the grab must still end at its deadline (or succeed).
  CaptureConfig config;
  config.source = "flood:";
  config.ring_frames = 3;
  StreamingCaptureService service(config, std::make_unique<FloodSource>());
  service.Start();
  const auto start = std::chrono::steady_clock::now();
  try {
    service.GrabBurst(3, BurstWhen::kNext, milliseconds(300));
  } catch (const CaptureUnavailable& e) {
    EXPECT_NE(std::string(e.what()).find("timed out"), std::string::npos) << e.what();
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  EXPECT_TRUE(service.Status().streaming);
}

TEST(CaptureServiceGaps, ABurstNeverSpansAGap) {
  // Frames 1-3, two lost, frames 4-9: the last 5 are fine, the last 8 are not.
  std::vector<ScriptedSource::Step> steps(9);
  steps[3].dropped_before = 2;
  StreamingCaptureService service(SmallConfig(), std::make_unique<ScriptedSource>(steps));
  service.Start();
  ASSERT_TRUE(WaitFor([&] { return service.Status().frames_captured == 9; }));
  EXPECT_EQ(service.Status().frames_dropped, 2u);
  const auto burst = service.GrabBurst(5, BurstWhen::kLast, milliseconds(1000));
  EXPECT_EQ(burst.manifest.source["source_sequence_first"], 5);
  EXPECT_EQ(burst.manifest.frames.front().sequence, 6);  // 3 frames + 2 lost before it
  try {
    service.GrabBurst(8, BurstWhen::kLast, milliseconds(50));
    FAIL() << "a burst across the gap was returned";
  } catch (const CaptureUnavailable& e) {
    EXPECT_NE(std::string(e.what()).find("consecutive"), std::string::npos) << e.what();
  }
}

TEST(CaptureServiceGaps, ABurstAfterARestartInPlaceReportsTheRestart) {
  // Frames 1-4, the stream restarted in place, frames 5-9: a burst of the
  // last 5 follows the restart, and its provenance must say so.
  std::vector<ScriptedSource::Step> steps(9);
  steps[4].restarted = true;
  StreamingCaptureService service(SmallConfig(), std::make_unique<ScriptedSource>(steps));
  service.Start();
  ASSERT_TRUE(WaitFor([&] { return service.Status().frames_captured == 9; }));
  const auto burst = service.GrabBurst(5, BurstWhen::kLast, milliseconds(1000));
  EXPECT_EQ(burst.manifest.source["source_sequence_first"], 5);
  EXPECT_EQ(burst.manifest.source["details"]["stream_restarts"], 1);
  // The restart is a discontinuity: no burst spans it.
  EXPECT_THROW(service.GrabBurst(6, BurstWhen::kLast, milliseconds(50)), CaptureUnavailable);
}

TEST(CaptureServiceGaps, DeviceGoneMidBurstIsReportedAndReopenIsADiscontinuity) {
  std::vector<ScriptedSource::Step> steps(4);
  steps[2].fail_gone = true;  // frames 1, 2, then the device goes, comes back for 1 more
  auto source = std::make_unique<ScriptedSource>(steps);
  ScriptedSource* raw = source.get();
  StreamingCaptureService service(SmallConfig(), std::move(source));
  service.Start();
  ASSERT_TRUE(WaitFor([&] { return service.Status().frames_captured == 3; }));
  const CaptureStatus status = service.Status();
  EXPECT_EQ(status.reconnects, 1u);
  EXPECT_EQ(raw->opens_, 2);
  // The frame after the reopen does not continue the ones before.
  EXPECT_THROW(service.GrabBurst(3, BurstWhen::kLast, milliseconds(50)), CaptureUnavailable);
  // Then the script ends: reopening fails with "gone", which a waiting grab reports.
  ASSERT_TRUE(WaitFor([&] { return !service.Status().streaming; }, milliseconds(10000)));
  try {
    service.GrabBurst(3, BurstWhen::kNext, milliseconds(5000));
    FAIL() << "no exception";
  } catch (const CaptureUnavailable& e) {
    EXPECT_NE(std::string(e.what()).find("gone"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dfsm::capture
