// The U->D direction of the contract's D->U radial model, tabulated: the sweep
// maps every sample from an undistorted ray to a captured pixel, and a Newton
// solve per sample would cost more than the sample itself.
#pragma once

#include <vector>

#include "core/camera/camera_model.h"

namespace dfsm {

class RadialInverse {
 public:
  // Tabulates r_d / r_u against r_u^2 by Newton's method on the radius, over
  // the undistorted radii of the whole captured image (plus a margin). Throws
  // std::invalid_argument naming the camera when the radial map folds over
  // inside the image.
  explicit RadialInverse(const CameraModel& camera);

  // r_d / r_u at squared undistorted radius r2: the captured pixel of the
  // undistorted normalized point (x_u, y_u) is c + f * Ratio(r2) * (x_u, y_u).
  // Negative where r2 lies outside the table (outside the image).
  float Ratio(float r2) const {
    const float t = r2 * inverse_step_;
    const int n = static_cast<int>(t);
    if (!(t >= 0.0f) || n >= kNodes - 1) return -1.0f;
    return ratio_[n] + (t - n) * (ratio_[n + 1] - ratio_[n]);
  }

 private:
  // r_d / r_u is smooth in r_u^2 (1 - k1 r^2 + ...): linear interpolation on
  // this many nodes is exact to ~1e-9 pixel-relative, far below the sweep's needs.
  static constexpr int kNodes = 4096;
  float inverse_step_ = 0.0f;
  std::vector<float> ratio_;
};

}  // namespace dfsm
