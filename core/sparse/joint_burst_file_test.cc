#include "core/sparse/joint_burst_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "core/io/file_util.h"
#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

class JointBurstFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("joint_burst_file_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    TrackSimulatorOptions simulate;
    simulate.width = 640;
    simulate.height = 480;
    simulate.f = 704.0;
    simulate.tracks = 60;
    const TrackSimulation sim = SimulateTracks(simulate);
    burst_.tracks = sim.tracks;
    burst_.state.camera = sim.camera;
    burst_.state.poses = sim.poses;
    burst_.state.inverse_depths = sim.inverse_depths;
    burst_.state.readout = 0.25;
    burst_.state.frame_times = {0, 1, 2, 4, 5, 6, 7, 8, 9, 10};
    burst_.use.assign(60, true);
    burst_.use[7] = false;
    burst_.noise_px = 0.21;
    burst_.sigma_f_percent = 3.5;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // The file's map with `spoil` applied, written back; the reader's refusal.
  std::string Refusal(void (*spoil)(nlohmann::json*)) {
    const std::filesystem::path path = dir_ / "tracks.cbor";
    WriteJointBurst(path, burst_);
    nlohmann::json j = nlohmann::json::from_cbor(ReadFileToString(path));
    spoil(&j);
    WriteFileAtomically(path, nlohmann::json::to_cbor(j));
    try {
      ReadJointBurst(path);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "no error";
  }

  std::filesystem::path dir_;
  JointBurst burst_;
};

TEST_F(JointBurstFile, RoundTripsWhatTheJointAdjustmentReads) {
  const std::filesystem::path path = dir_ / "tracks.cbor";
  WriteJointBurst(path, burst_);
  EXPECT_LT(std::filesystem::file_size(path), 20000u);
  const JointBurst read = ReadJointBurst(path);
  EXPECT_EQ(read.name, path.string());
  EXPECT_EQ(read.tracks.reference, burst_.tracks.reference);
  ASSERT_EQ(read.tracks.num_frames(), 10);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(read.tracks.pixels[i], burst_.tracks.pixels[i]);
    EXPECT_TRUE(read.state.poses[i].R.isApprox(burst_.state.poses[i].R, 1e-12));
    EXPECT_TRUE(read.state.poses[i].T.isApprox(burst_.state.poses[i].T, 1e-12));
  }
  EXPECT_EQ(read.state.inverse_depths, burst_.state.inverse_depths);
  EXPECT_EQ(read.use, burst_.use);
  EXPECT_EQ(read.state.frame_times, burst_.state.frame_times);
  EXPECT_EQ(read.state.camera.f, burst_.state.camera.f);
  EXPECT_EQ(read.state.camera.k2, burst_.state.camera.k2);
  EXPECT_EQ(read.state.camera.width, 640);
  EXPECT_EQ(read.state.readout, 0.25);
  EXPECT_EQ(read.noise_px, 0.21);
  EXPECT_EQ(read.sigma_f_percent, 3.5);
}

TEST_F(JointBurstFile, RefusesADamagedFileByWhatIsWrong) {
  EXPECT_NE(Refusal([](nlohmann::json* j) {
              (*j)["format"] = "dfsm-tracks/9";
            }).find("not of format dfsm-tracks/1"),
            std::string::npos);
  EXPECT_NE(Refusal([](nlohmann::json* j) {
              (*j)["pixels"][3].erase(0);
            }).find("frame 3's pixels holds 119 numbers, not 120"),
            std::string::npos);
  EXPECT_NE(Refusal([](nlohmann::json* j) { (*j)["reference"] = 10; }).find("\"reference\""),
            std::string::npos);
  EXPECT_NE(Refusal([](nlohmann::json* j) { (*j)["camera"]["f"] = -1.0; }).find("not positive"),
            std::string::npos);
  EXPECT_NE(
      Refusal([](nlohmann::json* j) { (*j)["frame_times"][4] = 1.0; }).find("do not increase"),
      std::string::npos);
  EXPECT_NE(Refusal([](nlohmann::json* j) { (*j)["poses"].erase(0); }).find("one pose per frame"),
            std::string::npos);
  EXPECT_NE(Refusal([](nlohmann::json* j) { j->erase("use"); }).find("no \"use\""),
            std::string::npos);
  const std::filesystem::path path = dir_ / "garbage.cbor";
  WriteFileAtomically(path, std::string("\xff\x00 not cbor", 11));
  try {
    ReadJointBurst(path);
    ADD_FAILURE() << "garbage was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dfsm
