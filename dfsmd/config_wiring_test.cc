// The composition root maps the daemon's option table onto the capture layer's
// types (daemon.cc, ToCaptureConfig); the two layers do not see each other, so
// this is where their lists are held together.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace dfsm
