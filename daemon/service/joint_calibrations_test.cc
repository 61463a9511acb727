#include "daemon/service/joint_calibrations.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/sparse/joint_burst_file.h"
#include "core/sparse/sparse_reconstruction.h"
#include "daemon/service/calibration_keeper.h"
#include "tests/support/track_simulator.h"

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

class JointCalibrationsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "jobs");
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path TracksOf(const std::string& job) const { return dir_ / "jobs" / job / kTracksFile; }

  // Job `job`'s tracks file: a 1080p burst of one camera (f 2100) through
  // the sparse stage, as a job of dfsmd leaves it.
  void WriteJob(const std::string& job, uint64_t seed) const {
    TrackSimulatorOptions simulate;
    simulate.tracks = 150;
    simulate.rotation_deg = 2.0;
    simulate.noise_px = 0.03;
    simulate.seed = seed;
    const TrackSimulation sim = SimulateTracks(simulate);
    SparseOptions options;
    options.rolling_shutter.mode = RollingShutterOptions::Mode::kGlobal;
    const SparseReconstruction sparse = ReconstructFromTracks(sim.tracks, 1920, 1080, options);
    fs::create_directories(TracksOf(job).parent_path());
    WriteJointBurst(TracksOf(job), JointBurstOf(job, sparse));
  }

  JointCalibrations::TracksOf Locator() const {
    return [this](const std::string& job) { return TracksOf(job); };
  }

  const fs::path dir_ =
      fs::temp_directory_path() / ("dfsm-joint-calibrations-" + std::to_string(::getpid()));
};

TEST_F(JointCalibrationsTest, RemembersTheNewestJobsAndSaysWhenOneIsDue) {
  JointCalibrations joint(dir_, 3, 2);
  EXPECT_FALSE(joint.Remember("camera 640x480", "j1"));
  EXPECT_FALSE(joint.Remember("camera 640x480", "j1"));  // run again: counted once
  EXPECT_TRUE(joint.Remember("camera 640x480", "j2"));
  EXPECT_FALSE(joint.Remember("camera 320x240", "k1"));  // another size, its own count
  joint.Remember("camera 640x480", "j3");
  joint.Remember("camera 640x480", "j4");
  const nlohmann::json snapshot = joint.Snapshot("camera 640x480");
  EXPECT_EQ(snapshot["jobs"], nlohmann::json({"j2", "j3", "j4"}));
  EXPECT_EQ(joint.current(), "camera 640x480");
  // Only on request: never due.
  JointCalibrations on_request(dir_ / "other", 3, 0);
  EXPECT_FALSE(on_request.Remember("camera 640x480", "j1"));
  EXPECT_TRUE(on_request.Snapshot("camera 640x480")["due_in"].is_null());
}

// The joint calibration of four jobs' tracks, a fifth job's file gone: the
// four join, the fifth is listed with why (its path not shown), the result
// survives a restart and, reliable, is the prior of the camera's next job.
TEST_F(JointCalibrationsTest, SolvesFromTheJobsTracksAndIsTheNextJobsPrior) {
  CalibrationSection config;
  config.joint_every = 0;
  {
    CalibrationKeeper keeper(config, "v4l2:/dev/video0", dir_);
    for (int k = 1; k <= 5; ++k) {
      if (k < 5) WriteJob("j" + std::to_string(k), k);
      EXPECT_FALSE(keeper.RememberTracks("j" + std::to_string(k), JobOptions{}, 1920, 1080));
    }
    const std::optional<nlohmann::json> result = keeper.SolveJoint(Locator());
    ASSERT_TRUE(result.has_value());
    EXPECT_EQ(result->at("bursts_joined"), 4) << result->dump(2);
    const nlohmann::json& gone = result->at("bursts").back();
    EXPECT_EQ(gone["name"], "j5");
    EXPECT_EQ(gone["outcome"], "unreadable");
    EXPECT_NE(gone["reason"].get<std::string>().find("job j5's tracks"), std::string::npos)
        << gone.dump();
    EXPECT_EQ(gone["reason"].get<std::string>().find(dir_.string()), std::string::npos);
  }
  CalibrationKeeper restarted(config, "v4l2:/dev/video0", dir_);
  const nlohmann::json snapshot = restarted.JointSnapshot();
  ASSERT_FALSE(snapshot["result"].is_null()) << snapshot.dump(2);
  const double f = snapshot["result"]["camera"]["fx"].get<double>();
  const double sigma = snapshot["result"]["uncertainty"]["sigma_f_percent"].get<double>();
  EXPECT_LE(std::abs(f - 2100.0), 2.0 * sigma / 100.0 * f) << snapshot.dump(2);
  ASSERT_EQ(snapshot["result"]["verdict"]["quality"], "reliable") << snapshot.dump(2);
  KnownCalibration known;
  ASSERT_TRUE(restarted.ForJob(JobOptions{}, 1920, 1080, &known));
  EXPECT_EQ(known.source, "joint (4 bursts, reliable)");
  EXPECT_TRUE(known.check_fit);
  EXPECT_DOUBLE_EQ(known.camera.f, f);
  // Another camera's job neither joins nor takes it.
  JobOptions upload;
  upload.camera = "other";
  EXPECT_FALSE(restarted.RememberTracks("u1", upload, 1920, 1080));
  EXPECT_FALSE(restarted.ForJob(upload, 1920, 1080, &known));
  restarted.Reset();
  EXPECT_TRUE(restarted.JointSnapshot()["result"].is_null());
}

TEST_F(JointCalibrationsTest, NothingToCalibrateFromIsSaid) {
  CalibrationSection config;
  CalibrationKeeper keeper(config, "v4l2:/dev/video0", dir_);
  EXPECT_THROW(keeper.SolveJoint(Locator()), std::runtime_error);
  keeper.RememberTracks("gone", JobOptions{}, 640, 480);
  try {
    keeper.SolveJoint(Locator());
    ADD_FAILURE() << "a joint calibration without tracks";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("has tracks to calibrate from"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dfsm::service
