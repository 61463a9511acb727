#include "daemon/capture/synthetic_source.h"

#include <gtest/gtest.h>

#include "daemon/capture/streaming_service.h"

namespace dfsm::capture {
namespace {

TEST(SyntheticSource, LoopsARenderedBurstWithItsGroundTruth) {
  CaptureConfig config;
  config.source = "synthetic:";
  config.width = 160;
  config.height = 90;
  config.fps = 200;
  config.ring_frames = 16;
  StreamingCaptureService service(config, std::make_unique<SyntheticSource>(config, 6));
  service.Start();
  const auto burst = service.GrabBurst(6, BurstWhen::kNext, std::chrono::seconds(30));
  service.Stop();
  ASSERT_EQ(burst.frames.size(), 6u);
  EXPECT_EQ(burst.frames[0].type(), CV_8UC3);
  EXPECT_EQ(burst.frames[0].cols, 160);
  const auto& source = burst.manifest.source;
  EXPECT_EQ(source["kind"], "synthetic");
  // Six frames of a six-frame loop: the grab restarts at the seam.
  EXPECT_EQ(source["source_sequence_first"], 0);
  EXPECT_EQ(source["details"]["ground_truth"]["poses"].size(), 6u);
  EXPECT_GT(cv::norm(burst.frames[0], burst.frames[5], cv::NORM_L1), 0.0);  // the camera moved
}

}  // namespace
}  // namespace dfsm::capture
