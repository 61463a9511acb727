// The shipped unit passes `systemd-analyze verify` and scores an exposure of
// at most 2.0 in `systemd-analyze security --offline=true`.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <regex>

#include "core/io/file_util.h"

namespace {

namespace fs = std::filesystem;

std::string RunCommand(const std::string& command, int* status) {
  std::string output;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  char buffer[4096];
  while (pipe && std::fgets(buffer, sizeof(buffer), pipe)) output += buffer;
  *status = pipe ? ::pclose(pipe) : -1;
  return output;
}

class SystemdUnitTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::system("command -v systemd-analyze >/dev/null 2>&1") != 0) {
      GTEST_SKIP() << "systemd-analyze is not installed (Debian package 'systemd')";
    }
    // The unit as installed: ExecStart pointing at the built binary.
    dir_ = fs::temp_directory_path() / ("dfsmd-unit-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    std::string unit = dfsm::ReadFileToString(fs::path(DFSM_SOURCE_DIR) / "systemd/dfsmd.service");
    unit = std::regex_replace(unit, std::regex("/usr/local/bin/dfsmd"), DFSMD_BINARY);
    dfsm::WriteFileAtomically(dir_ / "dfsmd.service", unit);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(SystemdUnitTest, Verifies) {
  int status = 0;
  const std::string output =
      RunCommand("systemd-analyze verify " + (dir_ / "dfsmd.service").string(), &status);
  EXPECT_EQ(status, 0) << output;
}

// The overall exposure systemd-analyze gives `unit` (a file in dir_).
double Exposure(const fs::path& unit) {
  int status = 0;
  const std::string output =
      RunCommand("systemd-analyze security --offline=true " + unit.string(), &status);
  std::smatch match;
  if (!std::regex_search(
          output, match,
          std::regex("Overall exposure level for " + unit.filename().string() + ": ([0-9.]+)"))) {
    ADD_FAILURE() << output;
    return 10.0;
  }
  std::cout << unit.filename().string() << ": exposure " << match[1] << "\n";
  return std::stod(match[1]);
}

TEST_F(SystemdUnitTest, ExposureAtMostTwo) { EXPECT_LE(Exposure(dir_ / "dfsmd.service"), 2.0); }

// Serving the network as docs/daemon.md says (a wider IPAddressAllow= and the
// token passed with LoadCredential=) keeps the exposure within the bound.
TEST_F(SystemdUnitTest, NetworkServingDropInStaysAtMostTwo) {
  std::string unit = dfsm::ReadFileToString(dir_ / "dfsmd.service");
  ASSERT_NE(unit.find("IPAddressAllow=localhost"), std::string::npos);
  unit = std::regex_replace(unit, std::regex("IPAddressAllow=localhost"),
                            "IPAddressAllow=any\nLoadCredential=dfsmd-token:/etc/dfsmd/token");
  dfsm::WriteFileAtomically(dir_ / "dfsmd-network.service", unit);
  EXPECT_LE(Exposure(dir_ / "dfsmd-network.service"), 2.0);
}

TEST_F(SystemdUnitTest, HasTheRequiredSettings) {
  const std::string unit = dfsm::ReadFileToString(dir_ / "dfsmd.service");
  for (const char* setting :
       {"Type=notify", "WatchdogSec=", "Restart=on-failure", "RestartPreventExitStatus=78",
        "DynamicUser=yes", "SupplementaryGroups=video", "StateDirectory=dfsmd",
        "ProtectSystem=strict", "PrivateTmp=yes", "PrivateMounts=yes", "NoNewPrivileges=yes",
        "DevicePolicy=closed", "DeviceAllow=char-video4linux rw", "DeviceAllow=char-media rw",
        "MemoryMax="}) {
    EXPECT_NE(unit.find(setting), std::string::npos) << setting;
  }
}

}  // namespace
