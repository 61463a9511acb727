#include "core/pipeline/frame_selection.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

namespace dfsm {
namespace {

Pose Turned(double degrees, const Eigen::Vector3d& axis, const Eigen::Vector3d& T) {
  Pose pose;
  pose.R = Eigen::AngleAxisd(degrees * M_PI / 180.0, axis.normalized()).toRotationMatrix();
  pose.T = T;
  return pose;
}

TEST(FrameSelection, APoseBetweenTwoIsTheirsLinearlyInTime) {
  const Eigen::Vector3d axis(0.2, 1.0, -0.3);
  const std::vector<Pose> poses = {Turned(1.0, axis, {0.0, 0.0, 0.0}),
                                   Turned(3.0, axis, {2.0, -1.0, 0.5})};
  const Pose middle = PoseAtTime({10.0, 14.0}, poses, 11.0);
  EXPECT_NEAR(RotationErrorDeg(middle.R, Turned(1.5, axis, Eigen::Vector3d::Zero()).R), 0.0, 1e-9);
  EXPECT_TRUE(middle.T.isApprox(Eigen::Vector3d(0.5, -0.25, 0.125), 1e-12));
  // Before the first and after the last: the motion carried on.
  const Pose before = PoseAtTime({10.0, 14.0}, poses, 8.0);
  EXPECT_NEAR(RotationErrorDeg(before.R, Turned(0.0, axis, Eigen::Vector3d::Zero()).R), 0.0, 1e-9);
  EXPECT_TRUE(before.T.isApprox(Eigen::Vector3d(-1.0, 0.5, -0.25), 1e-12));
  const Pose after = PoseAtTime({10.0, 14.0}, poses, 16.0);
  EXPECT_NEAR(RotationErrorDeg(after.R, Turned(4.0, axis, Eigen::Vector3d::Zero()).R), 0.0, 1e-9);
}

TEST(FrameSelection, TheNearestPairBracketsTheTime) {
  const Eigen::Vector3d axis(1.0, 0.0, 0.0);
  const std::vector<Pose> poses = {Turned(0.0, axis, {0, 0, 0}), Turned(1.0, axis, {1, 0, 0}),
                                   Turned(5.0, axis, {1, 4, 0})};
  const Pose pose = PoseAtTime({0.0, 1.0, 3.0}, poses, 2.0);
  EXPECT_NEAR(RotationErrorDeg(pose.R, Turned(3.0, axis, Eigen::Vector3d::Zero()).R), 0.0, 1e-9);
  EXPECT_TRUE(pose.T.isApprox(Eigen::Vector3d(1.0, 2.0, 0.0), 1e-12));
  EXPECT_THROW(PoseAtTime({0.0}, {poses[0]}, 0.5), std::invalid_argument);
}

TEST(FrameSelection, TheSelectedBurstKeepsItsReferenceAndSourceIndices) {
  Burst burst;
  burst.manifest.width = 4;
  burst.manifest.height = 2;
  burst.manifest.reference = 2;
  for (int i = 0; i < 5; ++i) {
    burst.gray.push_back(cv::Mat(2, 4, CV_8UC1, cv::Scalar(i)));
    BurstFrameInfo info;
    info.file = "frames/" + std::to_string(i) + ".png";
    info.sequence = 10 + i;
    burst.manifest.frames.push_back(info);
  }
  const Burst selected = SelectFrames(burst, {0, 2, 4});
  ASSERT_EQ(selected.size(), 3);
  EXPECT_EQ(selected.reference(), 1);
  EXPECT_EQ(selected.gray[2].at<uchar>(0, 0), 4);
  EXPECT_EQ(selected.manifest.frames[2].sequence, 14);
  EXPECT_EQ(selected.frame_indices(), (std::vector<int>{0, 2, 4}));
  // Indices into a burst that is itself a selection stay the caller's.
  EXPECT_EQ(SelectFrames(selected, {1, 2}).frame_indices(), (std::vector<int>{2, 4}));
  EXPECT_THROW(SelectFrames(burst, {0, 1}), std::invalid_argument);
  EXPECT_THROW(SelectFrames(burst, {2, 5}), std::out_of_range);
}

}  // namespace
}  // namespace dfsm
