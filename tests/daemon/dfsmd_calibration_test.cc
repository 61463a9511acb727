// The real dfsmd calibrating one camera over several of its bursts: each job's
// own estimate is fused (GET /api/v1/calibration "fused"), the fused sigma
// falls as bursts arrive and the fused camera nears the truth, the fusion
// survives a restart, and DELETE resets it. The joint calibration over the
// jobs' tracks is made after every calibration.joint_every jobs and on POST
// /api/v1/calibration/solve. Uploads feed it only when they
// say they come from the capture camera (camera=capture).
#include <gtest/gtest.h>
#include <signal.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "core/synth/burst_synthesizer.h"
#include "tests/daemon/fault_helpers.h"
#include "tests/support/tar_files.h"

namespace dfsm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Five bursts of one 640x480 camera: other scenes, other hand motions.
constexpr int kBursts = 5;

class DfsmdCalibrationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("dfsmd-calibration-test-" + std::to_string(::getpid()));
    fs::remove_all(root_);
    WriteTestBurst(root_ / "replay");
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  // Writes kBursts bursts of one 640x480 camera (other scenes, other hand
  // motions) as burst0..., and the same camera at another capture size (a
  // config change, a 320x240 upload of the same device), which must not claim
  // the camera's fusion, as small; returns the camera's focal length. Only
  // the test that uploads them renders them: each test runs in a process of
  // its own.
  static double WriteBursts() {
    double truth_f = 0.0;
    for (int i = 0; i < kBursts; ++i) {
      SynthOptions options;
      options.width = 640;
      options.height = 480;
      options.frames = 10;
      options.rotation_deg = 2.0;
      options.supersampling = 2;
      options.seed = 11 + i;
      const SynthBurst burst = SynthesizeBurst(options);
      truth_f = burst.truth.camera.f;
      WriteSynthBurst(root_ / ("burst" + std::to_string(i)), burst);
    }
    SynthOptions small;
    small.width = 320;
    small.height = 240;
    small.frames = 10;
    small.rotation_deg = 2.0;
    small.seed = 31;
    WriteSynthBurst(root_ / "small", SynthesizeBurst(small));
    return truth_f;
  }

  std::unique_ptr<DfsmdProcess> Start(const fs::path& state) {
    auto daemon = std::make_unique<DfsmdProcess>(
        DFSMD_BINARY,
        std::vector<std::string>{"--capture.source", "replay:" + (root_ / "replay").string(),
                                 "--jobs.state_dir", state.string()},
        state.parent_path() / "dfsmd.log");
    EXPECT_TRUE(daemon->ok()) << daemon->Log();
    return daemon;
  }

  static fs::path root_;
};

fs::path DfsmdCalibrationTest::root_;

TEST_F(DfsmdCalibrationTest, FusesTheBurstsOfOneCameraAndKeepsItAcrossARestart) {
  const double truth_f = WriteBursts();
  const fs::path dir = root_ / "run";
  fs::create_directories(dir);
  auto daemon = Start(dir / "state");
  httplib::Client client = daemon->Client();
  {
    // An upload that does not say it comes from the capture camera changes
    // nothing: it may be another camera's burst of the same size.
    const std::string tar = service::WriteTar(service::CollectFiles(root_ / "burst0"));
    const std::string location = AcceptedLocation(
        client.Post("/api/v1/jobs?dense=false&keep_burst=false", tar, "application/x-tar"));
    ASSERT_EQ(AwaitFinished(client, location)["status"], "succeeded");
    const json result = json::parse(client.Get((location + "/result.json").c_str())->body);
    EXPECT_NE(result.value("calibration_fusion", "").find("camera=capture"), std::string::npos)
        << result.dump(2);
    const json fused = json::parse(client.Get("/api/v1/calibration")->body)["fused"];
    EXPECT_TRUE(fused.value("empty", false)) << fused.dump(2);
  }
  {
    // One image size fused first used to lock every other size out.
    const std::string tar = service::WriteTar(service::CollectFiles(root_ / "small"));
    const std::string location = AcceptedLocation(client.Post(
        "/api/v1/jobs?dense=false&keep_burst=false&camera=capture", tar, "application/x-tar"));
    ASSERT_EQ(AwaitFinished(client, location)["status"], "succeeded");
  }
  std::vector<double> sigmas;
  for (int i = 0; i < kBursts; ++i) {
    const std::string tar =
        service::WriteTar(service::CollectFiles(root_ / ("burst" + std::to_string(i))));
    const std::string location = AcceptedLocation(client.Post(
        "/api/v1/jobs?dense=false&keep_burst=false&camera=capture", tar, "application/x-tar"));
    const json job = AwaitFinished(client, location);
    ASSERT_EQ(job["status"], "succeeded") << job.dump(2);
    const json result = json::parse(client.Get((location + "/result.json").c_str())->body);
    EXPECT_TRUE(result.contains("calibration_fusion")) << result.dump(2);
    const json fused = json::parse(client.Get("/api/v1/calibration")->body)["fused"];
    ASSERT_FALSE(fused.value("empty", true)) << fused.dump(2);
    sigmas.push_back(fused["sigma_f_percent"].get<double>());
  }
  const json calibration = json::parse(client.Get("/api/v1/calibration")->body);
  const json fused = calibration["fused"];
  std::cout << "fused: bursts " << fused["bursts"] << ", f " << fused["camera"]["fx"] << " (truth "
            << truth_f << "), sigma_f " << fused["sigma_f_percent"] << " %, distortion sigma "
            << fused["distortion_sigma_px"] << " px\n";
  EXPECT_GE(fused["bursts"].get<int>(), kBursts - 1);  // at most one outlier
  EXPECT_LT(sigmas.back(), 0.7 * sigmas.front());      // sigma falls as bursts are added
  const double f = fused["camera"]["fx"].get<double>();
  const double error_percent = 100.0 * std::abs(f - truth_f) / truth_f;
  EXPECT_LE(error_percent, 2.0 * fused["sigma_f_percent"].get<double>());
  EXPECT_LE(error_percent, 1.0);
  EXPECT_EQ(fused["history"].size(), static_cast<size_t>(kBursts));
  // The 320x240 burst went to a fusion of its own.
  EXPECT_NE(fused.value("key", "").find("640x480"), std::string::npos) << fused.dump(2);
  ASSERT_EQ(fused["other_sizes"].size(), 1u) << fused.dump(2);
  EXPECT_NE(fused["other_sizes"][0].value("key", "").find("320x240"), std::string::npos);

  // The joint calibration was made after the fourth 640x480 job
  // (calibration.joint_every); made again on request, it holds all five.
  const json made = calibration["joint"];
  EXPECT_NE(made.value("key", "").find("640x480"), std::string::npos) << made.dump(2);
  ASSERT_FALSE(made["result"].is_null()) << made.dump(2);
  EXPECT_EQ(made["result"]["bursts"].size(), 4u) << made.dump(2);
  // The solve runs on the request's thread: seconds, minutes under TSan.
  client.set_read_timeout(std::chrono::seconds(300));
  const auto solved = client.Post("/api/v1/calibration/solve", "{}", "application/json");
  ASSERT_TRUE(solved);
  ASSERT_EQ(solved->status, 200) << solved->body;
  const json joint = json::parse(solved->body);
  EXPECT_EQ(joint["jobs"].size(), static_cast<size_t>(kBursts)) << joint.dump(2);
  const json& result = joint["result"];
  std::cout << "joint: " << result["bursts_joined"] << " of " << result["bursts"].size()
            << " bursts, f " << result["camera"]["fx"] << " (truth " << truth_f << "), sigma_f "
            << result["uncertainty"]["sigma_f_percent"] << " %, " << result["verdict"]["quality"]
            << "\n";
  EXPECT_GE(result["bursts_joined"].get<int>(), kBursts - 1) << result.dump(2);
  const double joint_error =
      100.0 * std::abs(result["camera"]["fx"].get<double>() - truth_f) / truth_f;
  EXPECT_LE(joint_error, 2.0 * result["uncertainty"]["sigma_f_percent"].get<double>())
      << result.dump(2);

  // The fusion is stored: a restart keeps it.
  EXPECT_EQ(daemon->Stop(SIGTERM), 0) << daemon->Log();
  daemon = Start(dir / "state");
  httplib::Client restarted = daemon->Client();
  const json again = json::parse(restarted.Get("/api/v1/calibration")->body)["fused"];
  EXPECT_EQ(again["bursts"], fused["bursts"]);
  EXPECT_EQ(again["camera"]["fx"], fused["camera"]["fx"]);
  const json joint_again = json::parse(restarted.Get("/api/v1/calibration")->body)["joint"];
  EXPECT_EQ(joint_again["result"]["camera"], result["camera"]) << joint_again.dump(2);

  // DELETE forgets it (the history stays).
  const auto reset = restarted.Delete("/api/v1/calibration");
  ASSERT_TRUE(reset);
  EXPECT_EQ(reset->status, 204) << reset->body;
  const json after = json::parse(restarted.Get("/api/v1/calibration")->body)["fused"];
  EXPECT_TRUE(after.value("empty", false)) << after.dump(2);
  EXPECT_TRUE(json::parse(restarted.Get("/api/v1/calibration")->body)["joint"]["result"].is_null());
  EXPECT_EQ(daemon->Stop(SIGTERM), 0) << daemon->Log();
}

// A damaged fusion file never keeps dfsmd from starting: it is moved aside and
// the fusion restarts, and the API says so.
TEST_F(DfsmdCalibrationTest, ADamagedFusionFileIsMovedAside) {
  const fs::path dir = root_ / "damaged";
  fs::create_directories(dir / "state" / "calibration");
  std::ofstream(dir / "state" / "calibration" / "fusion.json") << "{\"format\": 12, [";
  auto daemon = Start(dir / "state");
  httplib::Client client = daemon->Client();
  const auto answer = client.Get("/api/v1/calibration");
  ASSERT_TRUE(answer);
  // No job yet: no calibration, an empty fusion, and no error.
  EXPECT_EQ(answer->status, 200);
  const json body = json::parse(answer->body);
  EXPECT_TRUE(body["calibration"].is_null()) << body;
  EXPECT_TRUE(body["fused"]["empty"].get<bool>()) << body;
  EXPECT_TRUE(fs::exists(dir / "state" / "calibration" / "fusion.json.damaged"));
  EXPECT_EQ(daemon->Stop(SIGTERM), 0) << daemon->Log();
}

}  // namespace
}  // namespace dfsm::test
