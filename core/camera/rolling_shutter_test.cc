#include "core/camera/rolling_shutter.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <stdexcept>

namespace dfsm {
namespace {

Pose MakePose(double yaw_deg, double tx) {
  Pose pose;
  pose.R = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  pose.T << tx, 0.0, 0.0;
  return pose;
}

TEST(RollingShutter, ParsesTheThreeFormsAndNamesWhatItRefuses) {
  EXPECT_EQ(ParseRollingShutter("global").mode, RollingShutterOptions::Mode::kGlobal);
  EXPECT_EQ(ParseRollingShutter("estimate").mode, RollingShutterOptions::Mode::kEstimate);
  const RollingShutterOptions known = ParseRollingShutter("0.6");
  EXPECT_EQ(known.mode, RollingShutterOptions::Mode::kKnown);
  EXPECT_DOUBLE_EQ(known.readout, 0.6);
  EXPECT_EQ(RollingShutterName(known), "0.6");
  EXPECT_EQ(ParseRollingShutter("0").mode, RollingShutterOptions::Mode::kGlobal);
  for (const char* bad : {"", "1.5", "-0.2", "0.6x", " 0.6", "nan", "rolling"}) {
    try {
      ParseRollingShutter(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("rolling shutter"), std::string::npos) << e.what();
    }
  }
}

TEST(RollingShutter, RowTimeIsZeroAtTheMiddleRowAndSpansTheReadout) {
  EXPECT_DOUBLE_EQ(RowTime(0.6, 239.5, 480), 0.0);
  EXPECT_NEAR(RowTime(0.6, -0.5, 480), -0.3, 1e-12);
  EXPECT_NEAR(RowTime(0.6, 479.5, 480), 0.3, 1e-12);
  EXPECT_DOUBLE_EQ(RowTime(0.0, 0.0, 480), 0.0);
}

TEST(RollingShutter, RowsInterpolateTheFramePosesOnTheirSide) {
  // Frames at yaw 0, 1, 3 degrees: rows below frame 1's middle move toward 3,
  // rows above toward 0, each at its own frame's rate.
  const std::vector<Pose> poses = {MakePose(0, 0), MakePose(1, 0.01), MakePose(3, 0.03)};
  const RowPoses rows(poses, 1.0, 100);
  const Pose bottom = rows.At(1, 99.5);  // dt = +0.5
  const Pose top = rows.At(1, -0.5);     // dt = -0.5
  EXPECT_NEAR(Eigen::AngleAxisd(bottom.R).angle() * 180 / M_PI, 2.0, 1e-9);
  EXPECT_NEAR(Eigen::AngleAxisd(top.R).angle() * 180 / M_PI, 0.5, 1e-9);
  EXPECT_NEAR(bottom.T.x(), 0.02, 1e-12);
  EXPECT_NEAR(top.T.x(), 0.005, 1e-12);
  // The middle row is the frame's pose; the ends extrapolate their neighbour.
  EXPECT_LT((rows.At(1, 49.5).R - poses[1].R).norm(), 1e-12);
  EXPECT_NEAR(rows.At(0, -0.5).T.x(), -0.005, 1e-12);
  EXPECT_NEAR(rows.At(2, 99.5).T.x(), 0.04, 1e-12);
}

// With angular velocities, a frame's rows turn at its own velocity about its
// middle row's rotation; the translation keeps the line to its neighbour.
TEST(RollingShutter, RowsTurnAtTheFramesOwnAngularVelocity) {
  const std::vector<Pose> poses = {MakePose(0, 0), MakePose(1, 0.01), MakePose(3, 0.03)};
  const double deg = M_PI / 180.0;
  // Frame 1 turns back at -2 deg per frame interval, against the line's +1 / +2.
  const AngularVelocities velocities = {Eigen::Vector3d(0, 1 * deg, 0),
                                        Eigen::Vector3d(0, -2 * deg, 0),
                                        Eigen::Vector3d(0, 2 * deg, 0)};
  const RowPoses rows(poses, 1.0, 100, {}, velocities);
  const Eigen::AngleAxisd bottom(rows.At(1, 99.5).R);  // dt = +0.5: 1 - 1 = 0 deg
  const Eigen::AngleAxisd top(rows.At(1, -0.5).R);     // dt = -0.5: 1 + 1 = 2 deg
  EXPECT_NEAR(bottom.angle(), 0.0, 1e-9);
  EXPECT_NEAR(top.angle() / deg, 2.0, 1e-9);
  EXPECT_NEAR(rows.At(1, 99.5).T.x(), 0.02, 1e-12);
  EXPECT_NEAR(rows.At(1, -0.5).T.x(), 0.005, 1e-12);
  // Velocities equal to the line's steps give the line's rows.
  const RowPoses line(poses, 1.0, 100);
  const RowPoses same(poses, 1.0, 100, {},
                      {Eigen::Vector3d(0, 1 * deg, 0), Eigen::Vector3d(0, 2 * deg, 0),
                       Eigen::Vector3d(0, 2 * deg, 0)});
  EXPECT_LT((same.At(1, 99.5).R - line.At(1, 99.5).R).norm(), 1e-12);
  EXPECT_LT((same.At(2, 10.0).R - line.At(2, 10.0).R).norm(), 1e-12);
  EXPECT_THROW(RowPoses(poses, 1.0, 100, {}, {Eigen::Vector3d::Zero()}), std::invalid_argument);
  EXPECT_THROW(
      CheckAngularVelocities(
          {Eigen::Vector3d(0, NAN, 0), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}, 3),
      std::invalid_argument);
}

// A frame dropped between frames 1 and 2 (capture times 0, 1, 3): the path
// from frame 1 to 2 spans two intervals, so a row half an interval after
// frame 1's middle has gone a quarter of the way, not half.
TEST(RollingShutter, RowsFollowTheCaptureTimesAcrossADroppedFrame) {
  const std::vector<Pose> poses = {MakePose(0, 0), MakePose(1, 0.01), MakePose(3, 0.03)};
  const RowPoses rows(poses, 1.0, 100, {0.0, 1.0, 3.0});
  EXPECT_NEAR(rows.At(1, 99.5).T.x(), 0.015, 1e-12);  // 0.01 + 0.5 * 0.02 / 2
  EXPECT_NEAR(rows.At(1, -0.5).T.x(), 0.005, 1e-12);  // the gap is on the other side
  EXPECT_NEAR(rows.At(2, -0.5).T.x(), 0.025, 1e-12);  // 0.03 - 0.5 * 0.02 / 2
  EXPECT_NEAR(rows.At(2, 99.5).T.x(), 0.035, 1e-12);  // extrapolates the same segment
  EXPECT_EQ(NeighbourOnSide(2, -0.5, 3, {0.0, 1.0, 3.0}).rate, -0.5);
  EXPECT_NO_THROW(CheckFrameTimes({}, 3));
  EXPECT_THROW(CheckFrameTimes({0.0, 1.0}, 3), std::invalid_argument);
  EXPECT_THROW(CheckFrameTimes({0.0, 2.0, 2.0}, 3), std::invalid_argument);
}

TEST(RollingShutter, RelativePoseOfAGlobalShutterIsTheFramePose) {
  const std::vector<Pose> poses = {MakePose(0, 0), MakePose(1, 0.01), MakePose(3, 0.03)};
  const RowPoses global(poses, 0.0, 100);
  const Pose relative = global.Relative(2, 10.0, 0, 90.0);
  EXPECT_LT((relative.R - poses[2].R).norm(), 1e-12);
  EXPECT_LT((relative.T - poses[2].T).norm(), 1e-12);
  // With a readout, the same rows of two frames: a point of the reference
  // row's camera lands where the two rows' world poses put it.
  const RowPoses rolling(poses, 0.8, 100);
  const Eigen::Vector3d X_world(0.3, -0.2, 2.0);
  const Pose a = rolling.At(0, 80.0), b = rolling.At(2, 80.0);
  const Pose ab = rolling.Relative(2, 80.0, 0, 80.0);
  EXPECT_LT((ab.Transform(a.Transform(X_world)) - b.Transform(X_world)).norm(), 1e-12);
}

TEST(RollingShutter, PoseParametersRoundTrip) {
  const Pose pose = MakePose(1.7, 0.02);
  const Pose back = FromPoseParameters(ToPoseParameters(pose));
  EXPECT_LT((back.R - pose.R).norm(), 1e-12);
  EXPECT_LT((back.T - pose.T).norm(), 1e-12);
  EXPECT_LT((FromPoseParameters(PoseParameters::Zero()).R - Eigen::Matrix3d::Identity()).norm(),
            1e-15);
}

}  // namespace
}  // namespace dfsm
