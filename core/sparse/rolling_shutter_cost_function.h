// RollingShutterReprojectionError with its Jacobian written out by the chain
// rule, for Ceres.
//
// Why not AutoDiffCostFunction: the residual touches 23 parameters (f, k1, k2;
// the poses of frame i, its neighbour n and the reference's neighbour m; w_j;
// the readout), so autodiff carries 23 derivatives through every operation of
// the two rotations and both undistortions. On a phone burst (1080p x 10, a
// readout of 0.6) that was ~27 % of a whole `dfsm process` (perf), more than
// the fine plane sweep. The chain rule below needs a few 3x3 products.
//
// The maths is RollingShutterReprojectionError::Evaluate's (the readable
// reference, which the tests hold this Jacobian to):
//
//     p      = undistort(u_ref; f, k1, k2),                 P = (p, 1)
//     a_r    = rho * t_r,  phi = -a_r * m_omega,  s = P - w * a_r * m_T
//     wX     = R(phi) s                                     (reference, middle row)
//     a_i    = rho * t_i,  Q = P_i + a_i (P_n - P_i)        (row pose of frame i)
//     X      = R(Q_omega) wX + w Q_T
//     r      = f (X_xy / X_z - undistort(u_obs; f, k1, k2))
//
// with d(R(phi) v)/d phi = -R(phi) [v]_x J_r(phi), J_r the right Jacobian of
// SO(3).
#pragma once

#include <ceres/cost_function.h>

#include "core/sparse/rolling_shutter_reprojection_error.h"

namespace dfsm {

class RollingShutterCostFunction : public ceres::CostFunction {
 public:
  using ReferenceNeighbour = RollingShutterReprojectionError::ReferenceNeighbour;

  // Parameter blocks {intrinsics (3), pose (6), neighbour (6),
  // [reference_neighbour (6),] inverse_depth (1), readout (1)}: the reference
  // neighbour's block only with kOwnBlock; otherwise it is frame i's pose
  // (kFrame) or its neighbour's (kFrameNeighbour).
  RollingShutterCostFunction(const RollingShutterReprojectionError& error,
                             ReferenceNeighbour shared);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  RollingShutterReprojectionError error_;
  ReferenceNeighbour shared_;
};

}  // namespace dfsm
