#include "core/export/calibration_export.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "core/io/file_util.h"

namespace dfsm {
namespace {

CameraModel Camera() {
  CameraModel camera = CameraModel::Initial(1920, 1080);
  camera.f = 2100.0;
  camera.k1 = -0.06;
  camera.k2 = 0.015;
  return camera;
}

TEST(CalibrationExport, OpenCvFitReproducesTheNativeModel) {
  const CameraModel camera = Camera();
  const OpenCvDistortionFit fit = FitOpenCvDistortion(camera);
  EXPECT_LT(fit.max_error_px, 0.05);
  // Independent check through OpenCV itself: project the undistorted
  // coordinate of captured pixels with the fitted model and land on them again.
  const cv::Matx33d K(camera.f, 0, camera.cx, 0, camera.f, camera.cy, 0, 0, 1);
  const std::vector<double> distortion = {fit.k1, fit.k2, 0.0, 0.0, fit.k3};
  for (const Eigen::Vector2d& pixel :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(1919, 1079), Eigen::Vector2d(400, 900)}) {
    const Eigen::Vector2d x = camera.PixelToUndistorted(pixel);
    std::vector<cv::Point3d> object = {{x.x(), x.y(), 1.0}};
    std::vector<cv::Point2d> image;
    cv::projectPoints(object, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, distortion, image);
    EXPECT_NEAR(image[0].x, pixel.x(), 0.05);
    EXPECT_NEAR(image[0].y, pixel.y(), 0.05);
  }
}

TEST(CalibrationExport, NoDistortionFitsToZero) {
  const OpenCvDistortionFit fit = FitOpenCvDistortion(CameraModel::Initial(640, 480));
  EXPECT_NEAR(fit.k1, 0.0, 1e-12);
  EXPECT_NEAR(fit.k2, 0.0, 1e-12);
  EXPECT_LT(fit.max_error_px, 1e-9);
}

TEST(CalibrationExport, WritesFilesOtherToolsRead) {
  const auto dir = std::filesystem::temp_directory_path() / "dfsm_calibration_export_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const CameraModel camera = Camera();
  WriteCalibrationFiles(dir, camera);

  cv::FileStorage yaml((dir / "calibration.yaml").string(), cv::FileStorage::READ);
  ASSERT_TRUE(yaml.isOpened());
  cv::Mat K, D;
  yaml["camera_matrix"] >> K;
  yaml["distortion_coefficients"] >> D;
  EXPECT_EQ(K.at<double>(0, 0), 2100.0);
  EXPECT_EQ(K.at<double>(1, 2), 540.0);
  ASSERT_EQ(D.total(), 5u);
  EXPECT_LT(static_cast<double>(yaml["distortion_fit_max_error_px"]), 0.05);

  const auto json = nlohmann::json::parse(ReadFileToString(dir / "calibration.json"));
  EXPECT_EQ(json["camera_matrix"]["data"][0], 2100.0);
  EXPECT_EQ(json["distortion_model"], "plumb_bob");
  EXPECT_EQ(CameraModelFromJson(json["native"]).k1, -0.06);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dfsm
