// The camera model of CONTRACT.md section 1: a square-pixel pinhole with the
// two-coefficient radial model of Ha et al. (CVPR 2016), written in the
// Distorted -> Undistorted direction ("ha2016-d2u").
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <nlohmann/json_fwd.hpp>
#include <optional>

namespace dfsm {

inline constexpr const char* kDistortionModelName = "ha2016-d2u";

// The D->U radial factor (1 + k1 r^2 + k2 r^4), templated so that Ceres cost
// functors and plain code share one definition of the model.
template <typename T>
T RadialFactor(const T& k1, const T& k2, const T& r2) {
  return T(1.0) + r2 * (k1 + k2 * r2);
}

// Maps a captured (distorted) pixel to its undistorted normalized coordinate.
template <typename T>
void PixelToUndistorted(const T& f, const T& k1, const T& k2, double cx, double cy, double u,
                        double v, T* x_u, T* y_u) {
  const T x_d = (T(u) - T(cx)) / f;
  const T y_d = (T(v) - T(cy)) / f;
  const T factor = RadialFactor(k1, k2, x_d * x_d + y_d * y_d);
  *x_u = x_d * factor;
  *y_u = y_d * factor;
}

struct CameraModel {
  int width = 0;
  int height = 0;
  double f = 0.0;  // fx = fy = f, in pixels
  double cx = 0.0;
  double cy = 0.0;
  double k1 = 0.0;
  double k2 = 0.0;

  // The initial guess of the pipeline: f = max(width, height), principal point
  // at the image centre, no distortion.
  static CameraModel Initial(int width, int height);

  // Distance from the principal point to the farthest corner of the image,
  // pixels: how far out the lens model must hold.
  double CornerRadiusPx() const {
    return std::hypot(std::max(cx, width - cx), std::max(cy, height - cy));
  }

  Eigen::Vector2d PixelToUndistorted(const Eigen::Vector2d& pixel) const;

  // Inverse of PixelToUndistorted by Newton's method on the radius. Empty when
  // the model is not invertible there (the radial map folds over), which for
  // sane coefficients happens only far outside the image.
  std::optional<Eigen::Vector2d> UndistortedToPixel(const Eigen::Vector2d& x_u) const;

  // Undistorted normalized coordinate -> pixel of an ideal pinhole camera with
  // the same f and principal point (the "undistorted image" grid).
  Eigen::Vector2d UndistortedToIdealPixel(const Eigen::Vector2d& x_u) const {
    return {f * x_u.x() + cx, f * x_u.y() + cy};
  }
};

// The coordinate, on an image reduced by the integer factor n (each pixel the
// mean of an n x n block, as cv::resize's INTER_AREA and the sweep's levels
// reduce), of captured coordinate p: the block's centre, captured n x + (n - 1) / 2,
// is reduced x.
inline double ReducedPixel(double p, int n) { return (p - 0.5 * (n - 1)) / n; }

// Mean distance in pixels between a grid of pixels and their round trip through
// `estimated` (D->U) and `truth` (U->D): the distortion metric of Ha et al.
// Pixels whose round trip is undefined are counted in `*failed` when given.
double MeanDistortionError(const CameraModel& estimated, const CameraModel& truth, int step = 8,
                           int* failed = nullptr);

// JSON as CONTRACT.md writes a calibration: {width, height, fx, fy, cx, cy, k1, k2,
// distortion_model}. FromJson throws std::runtime_error naming the bad field.
nlohmann::json ToJson(const CameraModel& camera);
CameraModel CameraModelFromJson(const nlohmann::json& j);

}  // namespace dfsm
