#include "core/pipeline/lens_resampling.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/export/calibration_import.h"

namespace dfsm {
namespace {

// TUM RGB-D freiburg1's published calibration: a lens whose k3, tangential
// terms and fx != fy ha2016-d2u follows to 1.7 px RMS at 640x480.
ImportedCalibration TumFreiburg1() {
  return FitOpenCvCalibration(640, 480, 517.3, 516.5, 318.6, 255.3,
                              {0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
}

// A captured frame of one bright spot (Gaussian, sigma 1.5 px) at `centre`.
cv::Mat Spot(cv::Size size, const Eigen::Vector2d& centre) {
  cv::Mat image(size, CV_32FC1);
  for (int v = 0; v < size.height; ++v)
    for (int u = 0; u < size.width; ++u) {
      const double d2 = std::pow(u - centre.x(), 2) + std::pow(v - centre.y(), 2);
      image.at<float>(v, u) = static_cast<float>(std::exp(-d2 / (2 * 1.5 * 1.5)));
    }
  return image;
}

// Where the lens puts the undistorted normalized coordinate x_u: OpenCV's
// projection, the model's definition.
Eigen::Vector2d Seen(const OpenCvLens& lens, const Eigen::Vector2d& x_u) {
  std::vector<cv::Point2d> pixel;
  cv::projectPoints(
      std::vector<cv::Point3d>{{x_u.x(), x_u.y(), 1.0}}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
      cv::Matx33d(lens.fx, 0, lens.cx, 0, lens.fy, lens.cy, 0, 0, 1), lens.distortion, pixel);
  return {pixel[0].x, pixel[0].y};
}

Eigen::Vector2d Centroid(const cv::Mat& image) {
  const cv::Moments m = cv::moments(image);
  return {m.m10 / m.m00, m.m01 / m.m00};
}

TEST(LensResampling, PutsAPointWhereTheFittedModelSeesIt) {
  const ImportedCalibration tum = TumFreiburg1();
  ASSERT_TRUE(tum.lens.has_value());
  const LensResampling resampling(*tum.lens, tum.camera);
  const cv::Size size(640, 480);
  // Points toward the corners, where the fit misses the lens most.
  for (const Eigen::Vector2d& x_u : {Eigen::Vector2d(-0.52, -0.38), Eigen::Vector2d(0.5, 0.33),
                                     Eigen::Vector2d(0.45, -0.4), Eigen::Vector2d(0.0, 0.0)}) {
    SCOPED_TRACE(x_u.transpose());
    const Eigen::Vector2d captured = Seen(*tum.lens, x_u);
    const std::optional<Eigen::Vector2d> modelled = tum.camera.UndistortedToPixel(x_u);
    ASSERT_TRUE(modelled.has_value());
    const Eigen::Vector2d resampled = Centroid(resampling.IntoModel(Spot(size, captured)));
    EXPECT_LT((resampled - *modelled).norm(), 0.05);
    std::cout << "x_u " << x_u.transpose() << ": the lens puts it at " << captured.transpose()
              << ", the fit at " << modelled->transpose() << ", resampled at "
              << resampled.transpose() << "\n";
  }
}

TEST(LensResampling, TakesMapsBackOntoTheCapturedGrid) {
  const ImportedCalibration tum = TumFreiburg1();
  const LensResampling resampling(*tum.lens, tum.camera);
  // Each model pixel holds its own coordinates; back on the captured grid a
  // pixel must hold the model pixel nearest its ray.
  cv::Mat u_of(480, 640, CV_32FC1), v_of(480, 640, CV_32FC1);
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) u_of.at<float>(v, u) = u, v_of.at<float>(v, u) = v;
  const cv::Mat back_u = resampling.BackToCaptured(u_of), back_v = resampling.BackToCaptured(v_of);
  const auto seen = [&](const Eigen::Vector2d& model_pixel) {
    return Seen(*tum.lens, tum.camera.PixelToUndistorted(model_pixel));
  };
  double worst_excess = 0.0;
  int outside = 0;
  for (int v = 20; v < 460; v += 7)
    for (int u = 20; u < 620; u += 7) {
      const Eigen::Vector2d model_pixel(back_u.at<float>(v, u), back_v.at<float>(v, u));
      outside += model_pixel.isZero();
      // Rounded to the nearest model pixel, the ray is off by at most half
      // a pixel's diagonal on the model's grid, times the lens's scale
      // against the model's there.
      const Eigen::Vector2d dx = seen(model_pixel + Eigen::Vector2d(1, 0)) - seen(model_pixel);
      const Eigen::Vector2d dy = seen(model_pixel + Eigen::Vector2d(0, 1)) - seen(model_pixel);
      const double bound = 0.5 * (dx.cwiseAbs() + dy.cwiseAbs()).norm();
      worst_excess =
          std::max(worst_excess, (seen(model_pixel) - Eigen::Vector2d(u, v)).norm() - bound);
    }
  EXPECT_EQ(outside, 0);
  // Beyond the rounding: the maps' interpolation between nodes 8 px apart,
  // a few hundredths of a pixel in the corners where this lens bends fastest.
  EXPECT_LT(worst_excess, 0.06);
}

TEST(LensResampling, MovesPixelsByWhatTheFitMisses) {
  const ImportedCalibration tum = TumFreiburg1();
  const LensResampling resampling(*tum.lens, tum.camera);
  // The shift at a pixel is the fit's error there, on every pixel instead of
  // the fit's grid.
  EXPECT_NEAR(resampling.rms_shift_px(), tum.fit_rms_error_px, 0.25 * tum.fit_rms_error_px);
  EXPECT_GE(resampling.max_shift_px(), resampling.rms_shift_px());
  EXPECT_LT(resampling.max_shift_px(), 2.0 * tum.fit_max_error_px);
}

TEST(LensResampling, LeavesALensTheModelHoldsAlone) {
  // No distortion and fx = fy: the model is the lens, the frames stay.
  const OpenCvLens lens{500.0, 500.0, 320.0, 240.0, {}};
  const CameraModel model{640, 480, 500.0, 320.0, 240.0, 0.0, 0.0};
  const LensResampling resampling(lens, model);
  EXPECT_LT(resampling.max_shift_px(), 1e-4);
  cv::Mat frame(480, 640, CV_8UC1);
  cv::randu(frame, 0, 256);
  EXPECT_EQ(cv::norm(resampling.IntoModel(frame), frame, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace dfsm
