#include "core/io/stage_timer.h"

#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace dfsm {
namespace {

// A lap's carried time goes to the next lap: the laps still add up to the
// time that passed, and a lap never carries more than it lasted.
TEST(StageTimer, CarriesAWaitToTheNextLap) {
  std::vector<std::pair<std::string, double>> laps;
  StageTimer timer(&laps);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  timer.Lap("first", 15.0);
  timer.Lap("second");
  timer.Lap("third", 1e9);
  timer.Lap("fourth");
  ASSERT_EQ(laps.size(), 4u);
  EXPECT_GE(laps[0].second, 5.0);   // at least 20 ms passed, 15 carried
  EXPECT_GE(laps[1].second, 15.0);  // the carried 15 ms
  EXPECT_EQ(laps[2].second, 0.0);   // carried all it lasted, no more
  EXPECT_GE(laps[3].second, 0.0);
  EXPECT_LT(laps[3].second, 1e6);
}

// A stage that runs twice keeps one entry, in its first place, with the time
// of both runs: nothing of the first run is lost to the second.
TEST(StageTimer, AddsAStageThatRunsAgainToItsFirstLap) {
  std::vector<std::pair<std::string, double>> laps;
  StageTimer timer(&laps);
  std::this_thread::sleep_for(std::chrono::milliseconds(10));
  timer.Lap("adjustment");
  timer.Lap("fallback");
  std::this_thread::sleep_for(std::chrono::milliseconds(10));
  timer.Lap("adjustment");
  ASSERT_EQ(laps.size(), 2u);
  EXPECT_EQ(laps[0].first, "adjustment");
  EXPECT_EQ(laps[1].first, "fallback");
  EXPECT_GE(laps[0].second, 20.0);
}

}  // namespace
}  // namespace dfsm
