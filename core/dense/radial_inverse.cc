#include "core/dense/radial_inverse.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace dfsm {
namespace {

// r_d / r_u for the undistorted radius r_u by Newton's method on r_d, from
// `r_d` (the previous node's solution). Throws where the radial map folds.
double SolveRatio(const CameraModel& camera, double r_u, double* r_d) {
  if (r_u <= 0.0) return 1.0;
  if (*r_d <= 0.0) *r_d = r_u;
  for (int iteration = 0; iteration < 50; ++iteration) {
    const double r2 = *r_d * *r_d;
    const double dg = 1.0 + 3.0 * camera.k1 * r2 + 5.0 * camera.k2 * r2 * r2;
    if (dg <= 1e-6) break;
    const double update = (*r_d * RadialFactor(camera.k1, camera.k2, r2) - r_u) / dg;
    *r_d -= update;
    if (std::abs(update) < 1e-15) {
      if (*r_d <= 0.0) break;
      return *r_d / r_u;
    }
  }
  throw std::invalid_argument("dense: the radial model (k1 " + std::to_string(camera.k1) + ", k2 " +
                              std::to_string(camera.k2) +
                              ") is not invertible inside the image (undistorted radius " +
                              std::to_string(r_u) + ")");
}

}  // namespace

RadialInverse::RadialInverse(const CameraModel& camera) {
  if (camera.width <= 0 || camera.height <= 0 || !(camera.f > 0.0) || !std::isfinite(camera.f))
    throw std::invalid_argument("dense: camera needs a positive size and focal length (" +
                                std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                                ", f " + std::to_string(camera.f) + ")");
  if (!std::isfinite(camera.k1) || !std::isfinite(camera.k2) || !std::isfinite(camera.cx) ||
      !std::isfinite(camera.cy))
    throw std::invalid_argument("dense: camera has a non-finite coefficient");
  // The D->U map must be monotonic in the radius over the whole captured
  // image, or two captured pixels see the same ray.
  const double corner_r_d = std::hypot(std::max(camera.cx + 1.0, camera.width - camera.cx),
                                       std::max(camera.cy + 1.0, camera.height - camera.cy)) /
                            camera.f;
  for (int n = 1; n <= 256; ++n) {
    const double r2 = std::pow(corner_r_d * n / 256.0, 2);
    if (1.0 + 3.0 * camera.k1 * r2 + 5.0 * camera.k2 * r2 * r2 <= 0.0)
      throw std::invalid_argument("dense: the radial model (k1 " + std::to_string(camera.k1) +
                                  ", k2 " + std::to_string(camera.k2) +
                                  ") is not invertible inside the image (it folds over at "
                                  "distorted radius " +
                                  std::to_string(std::sqrt(r2)) + ")");
  }
  // The captured image's largest undistorted radius is then at a corner (one
  // pixel out, for a bilinear sample's neighbours): no sample beyond it lands
  // on the image, so the fit need not reach further. The 1 % margin is for
  // rounding only: a wider one reaches toward the fold of a wide lens just
  // outside its image, where the inverse grows like a square root that no
  // polynomial of degree 10 follows, and would refuse cameras that fit their
  // burst (docs/experiments/229-radial-inverse-range.md).
  double max_r2 = 0.0;
  for (const double u : {-1.0, static_cast<double>(camera.width)})
    for (const double v : {-1.0, static_cast<double>(camera.height)})
      max_r2 = std::max(max_r2, camera.PixelToUndistorted({u, v}).squaredNorm());
  max_r2 = 1.01 * max_r2 + 1e-12;

  constexpr int kNodes = 400;
  Eigen::VectorXd t(kNodes), ratio(kNodes);
  double r_d = 0.0;
  for (int n = 0; n < kNodes; ++n) {
    t(n) = static_cast<double>(n) / (kNodes - 1);
    ratio(n) = SolveRatio(camera, std::sqrt(t(n) * max_r2), &r_d);
  }
  // The lowest degree that reproduces the inverse to 1e-6 of the radius
  // (1e-3 px at a 1080p corner, 4e-4 px at a VGA one). Wide-angle lenses near
  // their fold need more than degree 10 for that; they are taken at the best
  // degree if it moves no sample by more than kTolerancePx at the largest
  // radius (an error e of the ratio moves a sample by e * f * r_u pixels):
  // below the sweep's own approximation of a sample's path along a pixel's
  // planes (0.01-0.02 px, docs/experiments/204-streamed-volumes-interpolated-samples.md). Refusing
  // them cost their depth its distortion (docs/experiments/227-radial-inverse-tolerance.md).
  constexpr double kTolerance = 1e-6;
  constexpr double kTolerancePx = 0.01;
  constexpr int kLawsonIterations = 40;
  double best_error = std::numeric_limits<double>::infinity();
  float best[kMaxDegree + 1] = {};
  max_r2_ = static_cast<float>(max_r2);
  inverse_max_r2_ = static_cast<float>(1.0 / max_r2);
  const auto vandermonde = [&](int degree) {
    Eigen::MatrixXd powers(kNodes, degree + 1);
    for (int n = 0; n < kNodes; ++n)
      for (int d = 0; d <= degree; ++d) powers(n, d) = std::pow(t(n), d);
    return powers;
  };
  // Takes `fit` as the coefficients and returns its largest error over the
  // nodes as Ratio() evaluates it (in float), keeping it if it is the best so
  // far.
  const auto take = [&](const Eigen::VectorXd& fit) {
    std::fill(std::begin(coefficients_), std::end(coefficients_), 0.0f);
    for (int d = 0; d < fit.size(); ++d) coefficients_[d] = static_cast<float>(fit(d));
    double worst = 0.0;
    for (int n = 0; n < kNodes; ++n)
      worst = std::max(worst, std::abs(Ratio(static_cast<float>(t(n) * max_r2)) - ratio(n)));
    if (worst < best_error) {
      best_error = worst;
      std::copy(std::begin(coefficients_), std::end(coefficients_), std::begin(best));
    }
    return worst;
  };
  for (int degree = 2; degree <= kMaxDegree; ++degree) {
    fit_error_ = take(vandermonde(degree).colPivHouseholderQr().solve(ratio));
    if (fit_error_ < kTolerance) return;
  }
  // Near a fold the least-squares fit's largest error sits at the last
  // nodes. Lawson's iteration reweights the nodes by their errors toward the
  // fit of least largest error (minimax) of the highest degree.
  const Eigen::MatrixXd powers = vandermonde(kMaxDegree);
  Eigen::VectorXd weight = Eigen::VectorXd::Constant(kNodes, 1.0 / kNodes);
  for (int iteration = 0; iteration < kLawsonIterations; ++iteration) {
    const Eigen::VectorXd root = weight.cwiseSqrt();
    const Eigen::VectorXd fit =
        (root.asDiagonal() * powers).colPivHouseholderQr().solve(root.cwiseProduct(ratio));
    take(fit);
    weight = weight.cwiseProduct((powers * fit - ratio).cwiseAbs());
    const double sum = weight.sum();
    if (!(sum > 0.0)) break;
    weight /= sum;
  }
  fit_error_ = best_error;
  std::copy(std::begin(best), std::end(best), std::begin(coefficients_));
  if (best_error * camera.f * std::sqrt(max_r2) < kTolerancePx) return;
  throw std::invalid_argument("dense: the inverse of the radial model (k1 " +
                              std::to_string(camera.k1) + ", k2 " + std::to_string(camera.k2) +
                              ") is not smooth enough over the image (fit error " +
                              std::to_string(fit_error_) + ")");
}

}  // namespace dfsm
