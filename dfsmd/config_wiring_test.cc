// The composition root maps the daemon's option table onto the capture layer's
// types (daemon.cc, ToCaptureConfig); the two layers do not see each other, so
// this is where their lists are held together.
#include <gtest/gtest.h>

#include "daemon/capture/capture_limits.h"
#include "daemon/capture/replay_source.h"
#include "daemon/service/config_keys.h"

namespace dfsm {
namespace {

TEST(ConfigWiring, EveryReplayLoopChoiceIsALoopOfTheReplaySource) {
  const service::ConfigKey* key = service::FindConfigKey("capture.replay_loop");
  ASSERT_NE(key, nullptr);
  ASSERT_EQ(key->choices.size(), 2u);
  for (const std::string& choice : key->choices)
    EXPECT_EQ(capture::ReplayLoopName(capture::ParseReplayLoop(choice)), choice);
}

TEST(ConfigWiring, TheCaptureKeysTakeTheCaptureLayersLimits) {
  const service::ConfigKey& ring = service::ConfigKeyNamed("capture.ring_frames");
  EXPECT_EQ(ring.min, capture::kMinRingFrames);
  EXPECT_EQ(ring.max, capture::kMaxRingFrames);
  const service::ConfigKey& buffers = service::ConfigKeyNamed("capture.device_buffers");
  EXPECT_EQ(buffers.min, capture::kMinDeviceBuffers);
  EXPECT_EQ(buffers.max, capture::kMaxDeviceBuffers);
  EXPECT_EQ(service::ConfigKeyNamed("pipeline.frames").max, capture::kMaxRingFrames);
}

}  // namespace
}  // namespace dfsm
