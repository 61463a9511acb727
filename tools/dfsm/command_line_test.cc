#include "tools/dfsm/command_line.h"

#include <gtest/gtest.h>

namespace dfsm::tools {
namespace {

std::string UsageErrorOf(CLI::App& app, const Args& args) {
  try {
    ParseCommandLine(app, args);
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(CommandLineTest, ReadsOptionsAndPositionalsInAnyOrder) {
  CLI::App app("test", "dfsm test");
  std::string burst, out;
  int frames = 0;
  app.add_option("BURST", burst)->required();
  app.add_option("--out", out)->required();
  app.add_option("--frames", frames)->check(FrameCount());
  EXPECT_FALSE(ParseCommandLine(app, {"--out=/tmp/o", "b", "--frames", "12"}));
  EXPECT_EQ(burst, "b");
  EXPECT_EQ(out, "/tmp/o");
  EXPECT_EQ(frames, 12);
}

TEST(CommandLineTest, BadCommandLinesAreUsageErrorsNamingTheOption) {
  const auto error = [](const Args& args) {
    CLI::App app("test", "dfsm test");
    int frames = 0;
    std::string out;
    app.add_option("--out", out)->required();
    app.add_option("--frames", frames)->check(FrameCount());
    return UsageErrorOf(app, args);
  };
  EXPECT_EQ(error({"--out", "o", "--frames", "0"}), "");  // 0: every frame
  EXPECT_EQ(error({"--out", "o", "--frames", "3"}), "");
  for (const char* frames : {"1", "2", "-1", "12abc"}) {
    EXPECT_NE(error({"--out", "o", "--frames", frames}).find("--frames"), std::string::npos)
        << frames;
  }
  EXPECT_NE(error({"--frames", "5"}).find("--out"), std::string::npos);
  EXPECT_NE(error({"--out", "o", "--fames", "5"}).find("--fames"), std::string::npos);
}

TEST(CommandLineTest, HelpIsAnAnswerNotAnError) {
  CLI::App app("test", "dfsm test");
  std::string out;
  app.add_option("--out", out)->required();
  testing::internal::CaptureStdout();
  EXPECT_EQ(ParseCommandLine(app, {"--help"}), 0);
  EXPECT_NE(testing::internal::GetCapturedStdout().find("--out"), std::string::npos);
}

}  // namespace
}  // namespace dfsm::tools
