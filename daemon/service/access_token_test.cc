// Where the bearer token comes from and the rule that a non-loopback address
// needs one: token files, systemd credentials, and the errors that stop dfsmd.
#include "daemon/service/access_token.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

constexpr const char* kToken = "0123456789abcdef0123456789abcdef";

class AccessTokenTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("access-token-test-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path Write(const std::string& name, const std::string& content, mode_t mode = 0600) {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << content;
    ::chmod(path.c_str(), mode);
    return path;
  }

  std::string ErrorOf(ServerConfig server, const char* credentials = nullptr) {
    try {
      ResolveAccessToken(&server, credentials);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  }

  fs::path dir_;
};

TEST(LoopbackTest, RecognisesLoopbackAddressesOnly) {
  for (const char* address : {"127.0.0.1", "127.1.2.3", "::1", "[::1]", "localhost",
                              "::ffff:127.0.0.1", "0:0:0:0:0:0:0:1"}) {
    EXPECT_TRUE(IsLoopbackAddress(address)) << address;
  }
  for (const char* address :
       {"0.0.0.0", "::", "192.168.1.10", "10.0.0.1", "128.0.0.1", "::ffff:10.0.0.1", "fe80::1",
        "example.com", "localhost.evil", "127.0.0.1.nip.io", ""}) {
    EXPECT_FALSE(IsLoopbackAddress(address)) << address;
  }
}

TEST_F(AccessTokenTest, LoopbackNeedsNoToken) {
  ServerConfig server;
  ResolveAccessToken(&server, nullptr);
  EXPECT_TRUE(server.token.empty());
}

TEST_F(AccessTokenTest, NonLoopbackWithoutTokenIsAConfigError) {
  for (const char* address : {"0.0.0.0", "::", "192.168.1.10"}) {
    ServerConfig server;
    server.listen = address;
    const std::string error = ErrorOf(server);
    EXPECT_NE(error.find("server.listen: '" + std::string(address) + "' is not a loopback address"),
              std::string::npos)
        << error;
    EXPECT_NE(error.find("server.token_file"), std::string::npos) << error;
    EXPECT_NE(error.find("LoadCredential="), std::string::npos) << error;
  }
}

TEST_F(AccessTokenTest, TokenFileIsReadWithoutItsNewline) {
  ServerConfig server;
  server.listen = "0.0.0.0";
  server.token_file = Write("token", std::string(kToken) + "\n");
  ResolveAccessToken(&server, nullptr);
  EXPECT_EQ(server.token, kToken);
  server.token_file = Write("crlf", std::string(kToken) + "\r\n");
  ResolveAccessToken(&server, nullptr);
  EXPECT_EQ(server.token, kToken);
}

TEST_F(AccessTokenTest, TokenFileOnLoopbackIsUsedToo) {
  ServerConfig server;
  server.token_file = Write("token", kToken);
  ResolveAccessToken(&server, nullptr);
  EXPECT_EQ(server.token, kToken);
}

TEST_F(AccessTokenTest, BadTokenFilesAreRefusedByName) {
  ServerConfig server;
  server.listen = "0.0.0.0";
  server.token_file = dir_ / "absent";
  EXPECT_NE(ErrorOf(server).find("server.token_file: '" + (dir_ / "absent").string() +
                                 "': cannot read the token file: No such file"),
            std::string::npos)
      << ErrorOf(server);
  server.token_file = Write("empty", "\n");
  EXPECT_NE(ErrorOf(server).find("the token file is empty"), std::string::npos);
  server.token_file = Write("short", "abc123\n");
  EXPECT_NE(ErrorOf(server).find("the token has 6 characters; at least 16 are required"),
            std::string::npos)
      << ErrorOf(server);
  server.token_file = Write("spaces", "0123456789 abcdef0123\n");
  EXPECT_NE(ErrorOf(server).find("printable ASCII without spaces"), std::string::npos);
  server.token_file = Write("two-lines", std::string(kToken) + "\n" + kToken + "\n");
  EXPECT_NE(ErrorOf(server).find("printable ASCII without spaces"), std::string::npos);
  server.token_file = Write("long", std::string(kMaxTokenLength + 1, 'a'));
  EXPECT_NE(ErrorOf(server).find("longer than 4096"), std::string::npos);
  server.token_file = Write("public", kToken, 0644);
  EXPECT_NE(ErrorOf(server).find("readable by every user"), std::string::npos);
  server.token_file = dir_;
  EXPECT_NE(ErrorOf(server).find("not a regular file"), std::string::npos);
}

TEST_F(AccessTokenTest, SystemdCredentialIsTheFallback) {
  ServerConfig server;
  server.listen = "::";
  Write("dfsmd-token", std::string(kToken) + "\n", 0400);
  ResolveAccessToken(&server, dir_.c_str());
  EXPECT_EQ(server.token, kToken);

  // Another credential name, and one systemd did not pass.
  server.token_credential = "api-token";
  EXPECT_NE(ErrorOf(server, dir_.c_str()).find("pass the credential 'api-token'"),
            std::string::npos);
  Write("api-token", "short", 0400);
  EXPECT_NE(ErrorOf(server, dir_.c_str()).find("server.token_credential: '"), std::string::npos);
}

TEST_F(AccessTokenTest, TokenFileWinsOverTheCredential) {
  ServerConfig server;
  server.listen = "0.0.0.0";
  Write("dfsmd-token", std::string(kToken) + "\n");
  server.token_file = Write("token", "fedcba9876543210fedcba\n");
  ResolveAccessToken(&server, dir_.c_str());
  EXPECT_EQ(server.token, "fedcba9876543210fedcba");
}

TEST_F(AccessTokenTest, ParseCommandLineRefusesAnExposedDaemonWithoutToken) {
  ::unsetenv("CREDENTIALS_DIRECTORY");
  try {
    ParseCommandLine({"--server.listen", "0.0.0.0", "--jobs.state_dir", dir_.string()});
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("server.listen: '0.0.0.0' is not a loopback"),
              std::string::npos)
        << e.what();
  }
  const fs::path token = Write("token", kToken);
  const CommandLine line = ParseCommandLine({"--server.listen", "0.0.0.0", "--server.token_file",
                                             token.string(), "--jobs.state_dir", dir_.string()});
  EXPECT_EQ(line.config.server.token, kToken);
  EXPECT_THROW(ParseCommandLine({"--server.token_credential", "../x"}), ConfigError);
}

}  // namespace
}  // namespace dfsm::service
