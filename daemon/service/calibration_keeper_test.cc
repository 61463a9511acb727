#include "daemon/service/calibration_keeper.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "core/io/file_util.h"
#include "core/sparse/calibration_fusion.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

// A burst's own estimate as the sparse stage reports it: f within 0.2 %,
// reliable.
SparseReconstruction Estimate(int width, int height, double f) {
  SparseReconstruction sparse;
  sparse.calibration_used = CalibrationSource::kSelf;
  sparse.state.camera = CameraModel::Initial(width, height);
  sparse.state.camera.f = f;
  sparse.state.camera.k1 = -0.05;
  sparse.uncertainty.available = true;
  sparse.uncertainty.covariance.diagonal() << std::pow(0.002 * f, 2), 1e-6, 1e-6;
  sparse.verdict.quality = CalibrationQuality::kReliable;
  return sparse;
}

JobOptions Upload(const std::string& camera) {
  JobOptions options;
  options.camera = camera;
  return options;
}

class CalibrationKeeperTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  CalibrationKeeper Keeper() const {
    CalibrationSection config;
    return CalibrationKeeper(config, "v4l2:/dev/video0", dir_);
  }

  const fs::path dir_ =
      fs::temp_directory_path() / ("dfsm-calibration-keeper-" + std::to_string(::getpid()));
};

// Three uploads of another camera (f = 560) fused into the capture camera
// (f = 704) made the next captures run under f 562 as a reliable prior.
TEST_F(CalibrationKeeperTest, AnUploadOfAnotherCameraNeitherFeedsNorUsesTheCalibration) {
  CalibrationKeeper keeper = Keeper();
  for (int i = 0; i < 3; ++i) {
    const std::string said =
        keeper.Record("upload" + std::to_string(i), Upload("other"), i, Estimate(640, 480, 560));
    EXPECT_NE(said.find("camera=capture"), std::string::npos) << said;
  }
  EXPECT_TRUE(keeper.Snapshot().value("empty", false)) << keeper.Snapshot().dump(2);
  for (int i = 0; i < 3; ++i)
    keeper.Record("capture" + std::to_string(i), JobOptions{}, 10 + i, Estimate(640, 480, 704));
  KnownCalibration known;
  ASSERT_TRUE(keeper.ForJob(JobOptions{}, 640, 480, &known));
  EXPECT_NEAR(known.camera.f, 704.0, 0.5);
  // The fused prior is checked against the burst, as a file's camera is.
  EXPECT_TRUE(known.check_fit);
  EXPECT_FALSE(keeper.ForJob(Upload("other"), 640, 480, &known));
  EXPECT_TRUE(keeper.ForJob(Upload("capture"), 640, 480, &known));
}

// calibration.file in OpenCV's model: a job of its size gets the fitted
// camera and the file's lens, for the pipeline to resample the frames from.
TEST_F(CalibrationKeeperTest, AFilesOpenCvLensReachesTheJobs) {
  const fs::path file = dir_ / "camera.yaml";
  WriteFileAtomically(file, std::string("%YAML:1.0\n"
                                        "image_width: 640\n"
                                        "image_height: 480\n"
                                        "camera_matrix: !!opencv-matrix\n"
                                        "  rows: 3\n  cols: 3\n  dt: d\n"
                                        "  data: [517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1]\n"
                                        "distortion_coefficients: !!opencv-matrix\n"
                                        "  rows: 1\n  cols: 5\n  dt: d\n"
                                        "  data: [0.2624, -0.9531, -0.0054, 0.0026, 1.1633]\n"));
  CalibrationSection config;
  config.file = file;
  const CalibrationKeeper keeper(config, "v4l2:/dev/video0", dir_);
  KnownCalibration known;
  ASSERT_TRUE(keeper.ForJob(JobOptions{}, 640, 480, &known));
  EXPECT_NEAR(known.camera.f, 516.9, 1e-9);
  ASSERT_TRUE(known.lens.has_value());
  EXPECT_EQ(known.lens->fx, 517.3);
  EXPECT_EQ(known.lens->distortion.size(), 5u);
  // Another size calibrates alone: neither the camera nor its lens.
  KnownCalibration other;
  EXPECT_FALSE(keeper.ForJob(JobOptions{}, 1280, 720, &other));
  EXPECT_FALSE(other.lens.has_value());
}

// kill -9 between fusing and committing re-runs the job: it counts once.
TEST_F(CalibrationKeeperTest, AJobRunAgainIsCountedOnce) {
  {
    CalibrationKeeper keeper = Keeper();
    EXPECT_EQ(keeper.Record("j1", JobOptions{}, 1, Estimate(640, 480, 704)), "started");
  }
  CalibrationKeeper restarted = Keeper();  // the crash
  const std::string again = restarted.Record("j1", JobOptions{}, 2, Estimate(640, 480, 704));
  EXPECT_NE(again.find("already counted"), std::string::npos) << again;
  EXPECT_EQ(restarted.Snapshot()["bursts"], 1);
  EXPECT_EQ(restarted.Snapshot()["history"].size(), 1u);
}

// One 320x240 upload claimed the fusion and every 640x480 capture was refused.
TEST_F(CalibrationKeeperTest, EachImageSizeHasItsOwnFusion) {
  CalibrationKeeper keeper = Keeper();
  EXPECT_EQ(keeper.Record("small", JobOptions{}, 1, Estimate(320, 240, 352)), "started");
  for (int i = 0; i < 3; ++i) {
    const std::string said =
        keeper.Record("vga" + std::to_string(i), JobOptions{}, 2 + i, Estimate(640, 480, 704));
    EXPECT_EQ(said.rfind(i == 0 ? "started" : "fused", 0), 0u) << said;
  }
  const nlohmann::json snapshot = keeper.Snapshot();
  EXPECT_EQ(snapshot["key"], "v4l2:/dev/video0 640x480");
  EXPECT_EQ(snapshot["bursts"], 3);
  ASSERT_EQ(snapshot["other_sizes"].size(), 1u);
  EXPECT_EQ(snapshot["other_sizes"][0]["key"], "v4l2:/dev/video0 320x240");
  KnownCalibration known;
  EXPECT_TRUE(keeper.ForJob(JobOptions{}, 640, 480, &known));
  EXPECT_EQ(known.camera.width, 640);
  EXPECT_FALSE(keeper.ForJob(JobOptions{}, 320, 240, &known));  // one burst: not reliable
}

TEST_F(CalibrationKeeperTest, TheFusionsSurviveARestartAndAnOldFileIsRead) {
  {
    CalibrationKeeper keeper = Keeper();
    keeper.Record("a", JobOptions{}, 1, Estimate(320, 240, 352));
    keeper.Record("b", JobOptions{}, 2, Estimate(640, 480, 704));
  }
  const nlohmann::json before = Keeper().Snapshot();
  EXPECT_EQ(before["key"], "v4l2:/dev/video0 640x480");
  EXPECT_EQ(before["other_sizes"].size(), 1u);

  // A fusion.json of one fusion, as dfsmd stored it before sizes were kept apart.
  CalibrationFusion old;
  CalibrationSample sample;
  sample.camera = Estimate(640, 480, 700).state.camera;
  sample.covariance = Estimate(640, 480, 700).uncertainty.covariance;
  sample.job = "old";
  old.Add(sample);
  WriteFileAtomically(dir_ / "calibration" / "fusion.json", old.ToJson().dump());
  const nlohmann::json read = Keeper().Snapshot();
  EXPECT_EQ(read["key"], "v4l2:/dev/video0 640x480");
  EXPECT_EQ(read["bursts"], 1);
  EXPECT_EQ(read["history"][0]["job"], "old");
}

TEST_F(CalibrationKeeperTest, ResetForgetsEveryFusion) {
  CalibrationKeeper keeper = Keeper();
  keeper.Record("a", JobOptions{}, 1, Estimate(320, 240, 352));
  keeper.Record("b", JobOptions{}, 2, Estimate(640, 480, 704));
  keeper.Reset();
  EXPECT_TRUE(keeper.Snapshot().value("empty", false));
  EXPECT_EQ(keeper.Snapshot()["other_sizes"][0]["bursts"], 0);
  EXPECT_TRUE(Keeper().Snapshot().value("empty", false));
}

}  // namespace
}  // namespace dfsm::service
