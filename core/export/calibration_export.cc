#include "core/export/calibration_export.h"

#include <Eigen/Dense>
#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

#include "core/io/file_util.h"

namespace dfsm {

OpenCvDistortionFit FitOpenCvDistortion(const CameraModel& camera) {
  // Samples on a 32x32 grid over the captured image, corners included: the fit
  // must hold where the distortion is largest.
  constexpr int kSteps = 32;
  std::vector<double> r_u, ratio;
  for (int iy = 0; iy <= kSteps; ++iy) {
    for (int ix = 0; ix <= kSteps; ++ix) {
      const Eigen::Vector2d pixel(camera.width * ix / double(kSteps),
                                  camera.height * iy / double(kSteps));
      const double r_d = ((pixel - Eigen::Vector2d(camera.cx, camera.cy)) / camera.f).norm();
      const double r = camera.PixelToUndistorted(pixel).norm();
      if (r < 1e-9) continue;
      r_u.push_back(r);
      ratio.push_back(r_d / r);
    }
  }
  OpenCvDistortionFit fit;
  if (r_u.empty()) return fit;
  // Weight each sample by r_u so the residual is in radial distance, not ratio.
  Eigen::MatrixXd A(r_u.size(), 3);
  Eigen::VectorXd b(r_u.size());
  for (size_t i = 0; i < r_u.size(); ++i) {
    const double r2 = r_u[i] * r_u[i];
    A.row(i) << r_u[i] * r2, r_u[i] * r2 * r2, r_u[i] * r2 * r2 * r2;
    b[i] = r_u[i] * (ratio[i] - 1.0);
  }
  const Eigen::Vector3d c = A.colPivHouseholderQr().solve(b);
  fit.k1 = c[0], fit.k2 = c[1], fit.k3 = c[2];
  double sum_sq = 0.0;
  for (size_t i = 0; i < r_u.size(); ++i) {
    const double error_px = camera.f * std::abs(A.row(i).dot(c) - b[i]);
    fit.max_error_px = std::max(fit.max_error_px, error_px);
    sum_sq += error_px * error_px;
  }
  fit.rms_error_px = std::sqrt(sum_sq / r_u.size());
  return fit;
}

nlohmann::json WriteCalibrationFiles(const std::filesystem::path& out_dir,
                                     const CameraModel& camera, Flush flush) {
  const OpenCvDistortionFit fit = FitOpenCvDistortion(camera);
  const std::vector<double> camera_matrix = {camera.f,  0.0, camera.cx, 0.0, camera.f,
                                             camera.cy, 0.0, 0.0,       1.0};
  const std::vector<double> distortion = {fit.k1, fit.k2, 0.0, 0.0, fit.k3};

  const nlohmann::json json = {
      {"image_width", camera.width},
      {"image_height", camera.height},
      {"camera_matrix", {{"rows", 3}, {"cols", 3}, {"data", camera_matrix}}},
      {"distortion_model", "plumb_bob"},
      {"distortion_coefficients", {{"rows", 1}, {"cols", 5}, {"data", distortion}}},
      {"distortion_fit", {{"max_error_px", fit.max_error_px}, {"rms_error_px", fit.rms_error_px}}},
      {"native", ToJson(camera)}};
  WriteFileAtomically(out_dir / "calibration.json", json.dump(2) + "\n", flush);

  cv::FileStorage yaml(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  yaml << "image_width" << camera.width << "image_height" << camera.height;
  yaml << "camera_matrix" << cv::Mat(3, 3, CV_64F, const_cast<double*>(camera_matrix.data()));
  yaml << "distortion_coefficients"
       << cv::Mat(1, 5, CV_64F, const_cast<double*>(distortion.data()));
  yaml << "distortion_fit_max_error_px" << fit.max_error_px;
  yaml << "distortion_fit_rms_error_px" << fit.rms_error_px;
  yaml << "native_model" << kDistortionModelName;
  yaml << "native_k1" << camera.k1 << "native_k2" << camera.k2;
  WriteFileAtomically(out_dir / "calibration.yaml", yaml.releaseAndGetString(), flush);

  return {{"files", {"calibration.json", "calibration.yaml"}},
          {"opencv_fit_max_error_px", fit.max_error_px}};
}

}  // namespace dfsm
