#include "core/dense/radial_inverse.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace dfsm {

RadialInverse::RadialInverse(const CameraModel& camera) {
  if (camera.width <= 0 || camera.height <= 0 || !(camera.f > 0.0) || !std::isfinite(camera.f))
    throw std::invalid_argument("dense: camera needs a positive size and focal length (" +
                                std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                                ", f " + std::to_string(camera.f) + ")");
  if (!std::isfinite(camera.k1) || !std::isfinite(camera.k2) || !std::isfinite(camera.cx) ||
      !std::isfinite(camera.cy))
    throw std::invalid_argument("dense: camera has a non-finite coefficient");
  // The captured image's largest undistorted radius is at a corner, as long as
  // the D->U map is monotonic there (checked below through Newton).
  double max_r2 = 0.0;
  for (const double u : {-1.0, static_cast<double>(camera.width)})
    for (const double v : {-1.0, static_cast<double>(camera.height)}) {
      const Eigen::Vector2d x_u = camera.PixelToUndistorted({u, v});
      max_r2 = std::max(max_r2, x_u.squaredNorm());
    }
  max_r2 = 1.1 * max_r2 + 1e-12;
  const double step = max_r2 / (kNodes - 1);
  inverse_step_ = static_cast<float>(1.0 / step);
  ratio_.resize(kNodes);
  ratio_[0] = 1.0f;
  double r_d = 0.0;
  for (int n = 1; n < kNodes; ++n) {
    const double r_u = std::sqrt(n * step);
    if (r_d <= 0.0) r_d = r_u;  // warm start from the previous node otherwise
    bool converged = false;
    for (int iteration = 0; iteration < 50; ++iteration) {
      const double r2 = r_d * r_d;
      const double dg = 1.0 + 3.0 * camera.k1 * r2 + 5.0 * camera.k2 * r2 * r2;
      if (dg <= 1e-6) break;
      const double update = (r_d * RadialFactor(camera.k1, camera.k2, r2) - r_u) / dg;
      r_d -= update;
      if (std::abs(update) < 1e-14) {
        converged = true;
        break;
      }
    }
    const double r2 = r_d * r_d;
    if (!converged || r_d <= 0.0 || 1.0 + 3.0 * camera.k1 * r2 + 5.0 * camera.k2 * r2 * r2 <= 0.0)
      throw std::invalid_argument("dense: the radial model (k1 " + std::to_string(camera.k1) +
                                  ", k2 " + std::to_string(camera.k2) +
                                  ") is not invertible inside the image (undistorted radius " +
                                  std::to_string(r_u) + ")");
    ratio_[n] = static_cast<float>(r_d / r_u);
  }
}

}  // namespace dfsm
