// The real dfsmd bound beyond loopback: it refuses to start without a usable
// bearer token (exit 78, naming the problem), and with one (from a file or a
// systemd credential) serves only requests that carry it, probes excepted.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "core/synth/burst_synthesizer.h"
#include "dfsmd/dfsmd_process.h"

namespace dfsm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kToken = "c0ffee0123456789c0ffee0123456789";

class DfsmdSecurityTest : public ::testing::Test {
 protected:
  // A small replayed burst: starts streaming at once and stops at once.
  static void SetUpTestSuite() {
    burst_ = fs::temp_directory_path() / ("dfsmd-security-burst-" + std::to_string(::getpid()));
    fs::remove_all(burst_);
    SynthOptions options;
    options.width = 160;
    options.height = 120;
    options.frames = 5;
    WriteSynthBurst(burst_, SynthesizeBurst(options));
  }
  static void TearDownTestSuite() { fs::remove_all(burst_); }

  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dfsmd-security-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path WriteToken(const std::string& name, const std::string& content, mode_t mode) {
    const fs::path path = dir_ / name;
    std::ofstream(path) << content;
    ::chmod(path.c_str(), mode);
    return path;
  }

  // Every address, the replayed burst, no watchdog stall: nothing but the API matters here.
  std::vector<std::string> Args(const std::vector<std::string>& extra = {}) const {
    std::vector<std::string> args = {"--server.listen",
                                     "0.0.0.0",
                                     "--capture.source",
                                     "replay:" + burst_.string(),
                                     "--capture.stall_timeout_ms",
                                     "0",
                                     "--jobs.state_dir",
                                     (dir_ / "state").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }

  std::string Log(const std::string& name) const { return ReadFileToString(dir_ / name); }

  static fs::path burst_;
  fs::path dir_;
};

fs::path DfsmdSecurityTest::burst_;

TEST_F(DfsmdSecurityTest, RefusesToServeTheNetworkWithoutAToken) {
  EXPECT_EQ(RunDfsmd(DFSMD_BINARY, Args({"--server.port", "0"}), dir_ / "none.log"), 78);
  EXPECT_NE(Log("none.log")
                .find("dfsmd: invalid configuration: server.listen: '0.0.0.0' is not "
                      "a loopback address, so a bearer token is required"),
            std::string::npos)
      << Log("none.log");

  const fs::path readable = WriteToken("public-token", kToken, 0644);
  EXPECT_EQ(
      RunDfsmd(DFSMD_BINARY, Args({"--server.port", "0", "--server.token_file", readable.string()}),
               dir_ / "public.log"),
      78);
  EXPECT_NE(Log("public.log").find("readable by every user"), std::string::npos)
      << Log("public.log");

  const fs::path short_token = WriteToken("short-token", "secret\n", 0600);
  EXPECT_EQ(RunDfsmd(DFSMD_BINARY,
                     Args({"--server.port", "0", "--server.token_file", short_token.string()}),
                     dir_ / "short.log"),
            78);
  EXPECT_NE(Log("short.log").find("at least 16 are required"), std::string::npos)
      << Log("short.log");
  EXPECT_FALSE(fs::exists(dir_ / "state" / "jobs"));  // refused before touching the state
}

TEST_F(DfsmdSecurityTest, ServesOnlyRequestsWithTheToken) {
  const fs::path token = WriteToken("token", std::string(kToken) + "\n", 0600);
  DfsmdProcess daemon(DFSMD_BINARY, Args({"--server.token_file", token.string()}),
                      dir_ / "dfsmd.log", {}, /*wait_streaming=*/false);
  ASSERT_TRUE(daemon.ok()) << daemon.Log();
  httplib::Client anonymous = daemon.Client();
  httplib::Client client = daemon.Client();
  client.set_bearer_token_auth(kToken);

  EXPECT_EQ(anonymous.Get("/healthz")->status, 200);
  EXPECT_EQ(anonymous.Get("/api/v1/openapi.json")->status, 200);

  const auto refused = anonymous.Post("/api/v1/captures", "{}", "application/json");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 401);
  EXPECT_EQ(refused->get_header_value("Content-Type"), "application/problem+json");
  EXPECT_EQ(refused->get_header_value("WWW-Authenticate"), "Bearer realm=\"dfsmd\"");
  EXPECT_EQ(anonymous.Get("/api/v1/jobs")->status, 401);
  EXPECT_EQ(anonymous.Get("/metrics")->status, 401);
  httplib::Client wrong = daemon.Client();
  wrong.set_bearer_token_auth("c0ffee0123456789c0ffee012345678X");
  EXPECT_EQ(wrong.Get("/api/v1/camera")->status, 401);

  // The replay source streams its first frames after start-up.
  bool streaming = false;
  for (int i = 0; i < 1000 && !streaming; ++i) {
    const auto camera = client.Get("/api/v1/camera");
    ASSERT_EQ(camera->status, 200);
    streaming = json::parse(camera->body).value("streaming", false);
    if (!streaming) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(streaming) << daemon.Log();
  const auto accepted =
      client.Post("/api/v1/captures", R"({"frames":3,"dense":false})", "application/json");
  ASSERT_TRUE(accepted);
  ASSERT_EQ(accepted->status, 202) << accepted->body;
  const std::string location = accepted->get_header_value("Location");
  EXPECT_EQ(anonymous.Get(location.c_str())->status, 401);
  const auto job = client.Get(location.c_str());
  ASSERT_EQ(job->status, 200);
  EXPECT_EQ(json::parse(job->body)["id"], location.substr(13));
  EXPECT_EQ(anonymous.Delete(location.c_str())->status, 401);
  EXPECT_EQ(daemon.Stop(SIGTERM), 0);
}

TEST_F(DfsmdSecurityTest, TakesTheTokenFromASystemdCredential) {
  // What LoadCredential=dfsmd-token:/etc/dfsmd/token gives the service.
  fs::create_directories(dir_ / "credentials");
  WriteToken("credentials/dfsmd-token", kToken, 0400);
  DfsmdProcess daemon(DFSMD_BINARY, Args(), dir_ / "dfsmd.log",
                      {{"CREDENTIALS_DIRECTORY", (dir_ / "credentials").string()}},
                      /*wait_streaming=*/false);
  ASSERT_TRUE(daemon.ok()) << daemon.Log();
  httplib::Client anonymous = daemon.Client();
  httplib::Client client = daemon.Client();
  client.set_bearer_token_auth(kToken);
  EXPECT_EQ(anonymous.Get("/api/v1/jobs")->status, 401);
  EXPECT_EQ(client.Get("/api/v1/jobs")->status, 200);
  EXPECT_EQ(daemon.Stop(SIGTERM), 0);
}

}  // namespace
}  // namespace dfsm::test
