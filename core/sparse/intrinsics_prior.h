// A weak prior on the intrinsics of the self-calibrating adjustment.
//
// The focal length shows only through second-order terms of the rotational
// flow, so a burst with little rotation leaves f and k1/k2 in a flat valley of
// the reprojection cost; unchecked, the adjustment then drifts to cameras such
// as f = 17 max(w, h) with k2 = 5e4, which fit the tracks no better and ruin
// the dense stage. The prior holds f near the paper's initial guess in log
// scale and the distortion's displacement of image points near zero, both
// with widths far larger than any real lens needs, so a burst that does
// observe the camera is not moved by it (its cost curvature is orders of
// magnitude larger).
#pragma once

#include <ceres/ceres.h>

#include <cmath>

#include "core/camera/camera_model.h"

namespace dfsm {

class IntrinsicsPrior {
 public:
  // nominal_f: the centre of the focal prior (max(width, height));
  // corner_radius_px: distance from the principal point to the farthest corner.
  IntrinsicsPrior(double nominal_f, double corner_radius_px, double log_f_sigma,
                  double corner_shift_sigma_px)
      : nominal_f_(nominal_f),
        corner_radius_px_(corner_radius_px),
        log_f_sigma_(log_f_sigma),
        corner_shift_sigma_px_(corner_shift_sigma_px) {}

  // intrinsics = {f, k1, k2}
  template <typename T>
  bool operator()(const T* intrinsics, T* residuals) const {
    using std::log;
    const T& f = intrinsics[0];
    // A trial step of the trust region can carry f through zero (seen on
    // wide-angle sweep bursts). log would give NaN, which Ceres rejects the
    // same way but with a multi-line warning per occurrence on stderr, i.e.
    // in dfsmd's journal; refusing the evaluation rejects the step silently.
    if (!(f > T(0.0))) return false;
    residuals[0] = log(f / T(nominal_f_)) / T(log_f_sigma_);
    // How far the D->U model moves a pixel halfway to the corner and the
    // corner pixel itself, in pixels: two radii, so that k1 and k2 cannot
    // cancel at the corner while folding the image in between.
    for (int k = 0; k < 2; ++k) {
      const T radius_px = T(corner_radius_px_ * (k + 1) / 2.0);
      const T r = radius_px / f;
      residuals[1 + k] = radius_px * (RadialFactor(intrinsics[1], intrinsics[2], r * r) - T(1.0)) /
                         T(corner_shift_sigma_px_);
    }
    return true;
  }

  static ceres::CostFunction* Create(const CameraModel& camera, double log_f_sigma,
                                     double corner_shift_sigma_fraction) {
    const double corner = camera.CornerRadiusPx();
    return new ceres::AutoDiffCostFunction<IntrinsicsPrior, 3, 3>(
        new IntrinsicsPrior(std::max(camera.width, camera.height), corner, log_f_sigma,
                            corner_shift_sigma_fraction * corner));
  }

 private:
  double nominal_f_;
  double corner_radius_px_;
  double log_f_sigma_;
  double corner_shift_sigma_px_;
};

// A lens prior: real lenses need |k1|, |k2| of a few tenths at most in this
// model; each coefficient is zero-mean with the given sigma.
class LensPrior {
 public:
  explicit LensPrior(double sigma) : sigma_(sigma) {}
  template <typename T>
  bool operator()(const T* intrinsics, T* residuals) const {
    residuals[0] = intrinsics[1] / T(sigma_);
    residuals[1] = intrinsics[2] / T(sigma_);
    return true;
  }
  static ceres::CostFunction* Create(double sigma) {
    return new ceres::AutoDiffCostFunction<LensPrior, 2, 3>(new LensPrior(sigma));
  }

 private:
  double sigma_;
};

// A known calibration (a file the user gives, or the daemon's fused
// calibration) as a prior: f within sigma_f_percent of the known f, and the
// distortion's shift of the same two radii as IntrinsicsPrior within
// sigma_shift_px of the known model's shift there (0: no distortion term, only
// f is known).
class KnownIntrinsicsPrior {
 public:
  KnownIntrinsicsPrior(const CameraModel& known, double corner_radius_px, double sigma_f_percent,
                       double sigma_shift_px)
      : known_(known),
        corner_radius_px_(corner_radius_px),
        sigma_f_px_(known.f * sigma_f_percent / 100.0),
        sigma_shift_px_(sigma_shift_px) {}

  template <typename T>
  bool operator()(const T* intrinsics, T* residuals) const {
    const T& f = intrinsics[0];
    residuals[0] = (f - T(known_.f)) / T(sigma_f_px_);
    for (int k = 0; k < 2; ++k) {
      if (!(sigma_shift_px_ > 0.0)) {  // f alone is known (EXIF)
        residuals[1 + k] = T(0.0);
        continue;
      }
      const double radius_px = corner_radius_px_ * (k + 1) / 2.0;
      const T r = T(radius_px) / f;
      const double r_known = radius_px / known_.f;
      const T shift = T(radius_px) * (RadialFactor(intrinsics[1], intrinsics[2], r * r) -
                                      T(RadialFactor(known_.k1, known_.k2, r_known * r_known)));
      residuals[1 + k] = shift / T(sigma_shift_px_);
    }
    return true;
  }

  static ceres::CostFunction* Create(const CameraModel& known, double sigma_f_percent,
                                     double sigma_shift_px) {
    const double corner = known.CornerRadiusPx();
    return new ceres::AutoDiffCostFunction<KnownIntrinsicsPrior, 3, 3>(
        new KnownIntrinsicsPrior(known, corner, sigma_f_percent, sigma_shift_px));
  }

 private:
  CameraModel known_;
  double corner_radius_px_;
  double sigma_f_px_;
  double sigma_shift_px_;
};

}  // namespace dfsm
