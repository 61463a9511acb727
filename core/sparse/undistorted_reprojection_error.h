// The residual of Ha et al.'s self-calibrating bundle adjustment, in the
// undistorted domain and in inverse-depth form.
//
// Track j is the reference ray p_j = undistort(u_ref_j; f, k1, k2) at inverse
// depth w_j, i.e. X = (p_j, 1) / w_j. In frame i it lands on
//
//     X_i ∝ R_i (p_j, 1) + w_j T_i          (the same ray, scaled by w_j),
//
// which never divides by w_j, so a random or zero inverse depth is a valid
// starting point. The residual compares that projection with the undistorted
// observation of frame i, scaled by f so that it reads in pixels of the
// undistorted image. Both observations are undistorted with the current f, k1,
// k2, which is what lets the adjustment calibrate the camera.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "core/camera/camera_model.h"

namespace dfsm {

// The residual of a point X (camera coordinates, any scale) against the
// observed pixel, both in the undistorted domain, in pixels of f.
template <typename T>
void UndistortedResidual(const T* intrinsics, double cx, double cy, const Eigen::Vector2d& observed,
                         const T* X, T* residuals) {
  const T& f = intrinsics[0];
  T observed_x, observed_y;
  PixelToUndistorted(f, intrinsics[1], intrinsics[2], cx, cy, observed.x(), observed.y(),
                     &observed_x, &observed_y);
  residuals[0] = f * (X[0] / X[2] - observed_x);
  residuals[1] = f * (X[1] / X[2] - observed_y);
}

class UndistortedReprojectionError {
 public:
  UndistortedReprojectionError(const Eigen::Vector2d& reference_pixel,
                               const Eigen::Vector2d& observed_pixel, double cx, double cy)
      : reference_(reference_pixel), observed_(observed_pixel), cx_(cx), cy_(cy) {}

  // intrinsics = {f, k1, k2}; pose = {angle-axis R_i (3), T_i (3)}; inverse_depth = {w_j}.
  template <typename T>
  bool operator()(const T* intrinsics, const T* pose, const T* inverse_depth, T* residuals) const {
    const T& f = intrinsics[0];
    T p[3];
    PixelToUndistorted(f, intrinsics[1], intrinsics[2], cx_, cy_, reference_.x(), reference_.y(),
                       &p[0], &p[1]);
    p[2] = T(1.0);
    T X[3];
    ceres::AngleAxisRotatePoint(pose, p, X);
    for (int k = 0; k < 3; ++k) X[k] += inverse_depth[0] * pose[3 + k];
    UndistortedResidual(intrinsics, cx_, cy_, observed_, X, residuals);
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& reference_pixel,
                                     const Eigen::Vector2d& observed_pixel, double cx, double cy) {
    return new ceres::AutoDiffCostFunction<UndistortedReprojectionError, 2, 3, 6, 1>(
        new UndistortedReprojectionError(reference_pixel, observed_pixel, cx, cy));
  }

 private:
  Eigen::Vector2d reference_;
  Eigen::Vector2d observed_;
  double cx_, cy_;
};

}  // namespace dfsm
