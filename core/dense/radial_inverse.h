// The U->D direction of the contract's D->U radial model, as a polynomial: the
// sweep maps every sample from an undistorted ray to a captured pixel, and a
// Newton solve (or a table look-up, a gather) per sample would cost more than
// the sample itself and keep the loop from vectorizing.
#pragma once

#include <vector>

#include "core/camera/camera_model.h"

namespace dfsm {

class RadialInverse {
 public:
  // Solves r_d / r_u by Newton's method on the radius at nodes spanning the
  // undistorted radii of the whole captured image (plus a margin) and fits a
  // polynomial in r_u^2 to them. Throws std::invalid_argument naming the
  // camera when the radial map folds over inside the image, or when no
  // polynomial of degree <= 10 reproduces the inverse to 1e-6 of a pixel-radius.
  explicit RadialInverse(const CameraModel& camera);

  // r_d / r_u at squared undistorted radius r2 <= max_r2(): the captured pixel of
  // the undistorted normalized point (x_u, y_u) is c + f * Ratio(r2) * (x_u, y_u).
  float Ratio(float r2) const {
    // Horner written out: an inner loop would keep callers' loops from vectorizing.
    const float t = r2 * inverse_max_r2_;
    const float* c = coefficients_;
    return c[0] +
           t * (c[1] +
                t * (c[2] +
                     t * (c[3] +
                          t * (c[4] +
                               t * (c[5] +
                                    t * (c[6] +
                                         t * (c[7] + t * (c[8] + t * (c[9] + t * c[10])))))))));
  }
  float max_r2() const { return max_r2_; }
  // Largest |fitted - Newton| ratio over the check nodes (for tests and docs).
  double fit_error() const { return fit_error_; }

 private:
  static constexpr int kMaxDegree = 10;      // Ratio() spells out this many terms
  float coefficients_[kMaxDegree + 1] = {};  // in t = r2 / max_r2, unused ones 0
  float max_r2_ = 0.0f;
  float inverse_max_r2_ = 0.0f;
  double fit_error_ = 0.0;
};

}  // namespace dfsm
