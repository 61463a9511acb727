#include "core/camera/camera_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/camera/pose.h"

namespace dfsm {
namespace {

CameraModel DistortedCamera() {
  CameraModel camera = CameraModel::Initial(1920, 1080);
  camera.f = 1650.0;
  camera.k1 = -0.08;
  camera.k2 = 0.02;
  return camera;
}

TEST(CameraModel, InitialGuessFollowsThePaper) {
  const CameraModel camera = CameraModel::Initial(640, 480);
  EXPECT_EQ(camera.f, 640.0);
  EXPECT_EQ(camera.cx, 320.0);
  EXPECT_EQ(camera.cy, 240.0);
  EXPECT_EQ(camera.k1, 0.0);
  EXPECT_EQ(camera.k2, 0.0);
}

// The lens model must hold out to the farthest corner, wherever the
// principal point sits.
TEST(CameraModel, CornerRadiusIsTheFarthestCorner) {
  CameraModel camera = CameraModel::Initial(640, 480);
  EXPECT_DOUBLE_EQ(camera.CornerRadiusPx(), 400.0);
  camera.cx = 100.0;
  camera.cy = 300.0;
  EXPECT_DOUBLE_EQ(camera.CornerRadiusPx(), std::hypot(540.0, 300.0));
}

TEST(CameraModel, PixelToUndistortedMatchesTheContractFormula) {
  const CameraModel camera = DistortedCamera();
  const double u = 1700.0, v = 100.0;
  const double x_d = (u - camera.cx) / camera.f, y_d = (v - camera.cy) / camera.f;
  const double r2 = x_d * x_d + y_d * y_d;
  const double factor = 1.0 + camera.k1 * r2 + camera.k2 * r2 * r2;
  const Eigen::Vector2d x_u = camera.PixelToUndistorted({u, v});
  EXPECT_DOUBLE_EQ(x_u.x(), x_d * factor);
  EXPECT_DOUBLE_EQ(x_u.y(), y_d * factor);
}

TEST(CameraModel, UndistortedToPixelInvertsEveryPixelOfTheImage) {
  const CameraModel camera = DistortedCamera();
  for (int v = 0; v <= camera.height; v += 60) {
    for (int u = 0; u <= camera.width; u += 60) {
      const Eigen::Vector2d pixel(u, v);
      const auto back = camera.UndistortedToPixel(camera.PixelToUndistorted(pixel));
      ASSERT_TRUE(back.has_value()) << u << "," << v;
      EXPECT_NEAR((*back - pixel).norm(), 0.0, 1e-8);
    }
  }
}

TEST(CameraModel, UndistortedToPixelRefusesAFoldedModel) {
  CameraModel camera = CameraModel::Initial(100, 100);
  camera.k1 = -1.0;  // r (1 - r^2) peaks at r = 1/sqrt(3): larger radii have no inverse.
  EXPECT_FALSE(camera.UndistortedToPixel({0.9, 0.0}).has_value());
  EXPECT_TRUE(camera.UndistortedToPixel({0.1, 0.0}).has_value());
}

TEST(CameraModel, DistortionErrorIsZeroForTheTruthAndGrowsWithK1) {
  const CameraModel truth = DistortedCamera();
  EXPECT_NEAR(MeanDistortionError(truth, truth), 0.0, 1e-9);
  CameraModel off = truth;
  off.k1 += 0.01;
  const double error = MeanDistortionError(off, truth);
  EXPECT_GT(error, 0.5);
  EXPECT_LT(error, 10.0);
}

TEST(CameraModel, JsonRoundTripFollowsTheContract) {
  const CameraModel camera = DistortedCamera();
  const nlohmann::json j = ToJson(camera);
  EXPECT_EQ(j["distortion_model"], "ha2016-d2u");
  EXPECT_EQ(j["fx"], j["fy"]);
  const CameraModel back = CameraModelFromJson(j);
  EXPECT_EQ(back.width, camera.width);
  EXPECT_DOUBLE_EQ(back.f, camera.f);
  EXPECT_DOUBLE_EQ(back.k2, camera.k2);
}

TEST(CameraModel, JsonNamesTheBadField) {
  nlohmann::json j = ToJson(DistortedCamera());
  j.erase("cx");
  try {
    CameraModelFromJson(j);
    FAIL() << "accepted a calibration without cx";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cx"), std::string::npos) << e.what();
  }
}

TEST(Pose, JsonIsRowMajorAndRoundTrips) {
  Pose pose;
  pose.R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  pose.T << 0.1, 0.2, 0.3;
  const nlohmann::json j = ToJson(pose);
  EXPECT_EQ(j["R"][1].get<double>(), -1.0);
  const Pose back = PoseFromJson(j);
  EXPECT_NEAR(RotationErrorDeg(back.R, pose.R), 0.0, 1e-9);
  EXPECT_EQ(back.T, pose.T);
}

}  // namespace
}  // namespace dfsm
