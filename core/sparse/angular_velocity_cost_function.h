// AngularVelocityReprojectionError with its Jacobian written out by the chain
// rule, for Ceres: DifferentiateRowToRow's derivatives by the two row poses
// (row_to_row_jacobian.h, which says why not autodiff), carried onto the
// blocks of each frame's own angular velocity. With dt_r = rho t_r and
// dt_i = rho t_i (rho the readout, t the rows' times) and the sides' rates
// s_r, s_i:
//
//     reference row = [dt_r omega_ref,  dt_r s_r T_m],
//     observed row  = [r_i + dt_i omega_i,  T_i + dt_i s_i (T_n - T_i)].
//
// AngularVelocityReprojectionError::Evaluate is the readable reference the
// tests hold this Jacobian to.
#pragma once

#include <ceres/cost_function.h>

#include "core/sparse/angular_velocity_reprojection_error.h"

namespace dfsm {

class AngularVelocityCostFunction : public ceres::CostFunction {
 public:
  using ReferenceNeighbour = AngularVelocityReprojectionError::ReferenceNeighbour;

  // Parameter blocks {intrinsics (3), pose (6), neighbour (6),
  // [reference_neighbour (6),] velocity (3), reference_velocity (3),
  // inverse_depth (1), readout (1)}: the reference neighbour's block only with
  // kOwnBlock; otherwise it is frame i's pose (kFrame) or its neighbour's
  // (kFrameNeighbour).
  AngularVelocityCostFunction(const AngularVelocityReprojectionError& error,
                              ReferenceNeighbour shared);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  AngularVelocityReprojectionError error_;
  ReferenceNeighbour shared_;
};

}  // namespace dfsm
