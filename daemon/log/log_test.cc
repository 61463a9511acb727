#include "daemon/log/log.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace dfsm::log {
namespace {

// What `write` sends to stderr.
template <typename F>
std::string Captured(F write) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("dfsm-log-test-" + std::to_string(::getpid()));
  const int saved = ::dup(STDERR_FILENO);
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  ::dup2(fd, STDERR_FILENO);
  ::close(fd);
  write();
  ::dup2(saved, STDERR_FILENO);
  ::close(saved);
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  std::filesystem::remove(file);
  return text.str();
}

TEST(LogTest, OneWholeLineNamedByTheProgram) {
  const std::string text = Captured([] { Warning("capture: device gone: /dev/video0"); });
  EXPECT_NE(text.find(std::string(program_invocation_short_name) +
                      ": capture: device gone: /dev/video0\n"),
            std::string::npos)
      << text;
}

TEST(LogTest, LimitedLinesStopAtTheirRate) {
  int written = 0;
  const std::string text = Captured([&] {
    for (int i = 0; i < 10; ++i)
      written += WriteLimited(Priority::kNotice, "test key", "refused " + std::to_string(i), 3);
  });
  EXPECT_EQ(written, 3);
  EXPECT_NE(text.find("refused 2"), std::string::npos) << text;
  EXPECT_EQ(text.find("refused 3"), std::string::npos) << text;
}

}  // namespace
}  // namespace dfsm::log
