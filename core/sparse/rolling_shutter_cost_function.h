// RollingShutterReprojectionError with its Jacobian written out by the chain
// rule, for Ceres: DifferentiateRowToRow's derivatives by the two row poses
// (row_to_row_jacobian.h, which says why not autodiff), carried onto the
// line's parameter blocks. With a_r = rho t_r and a_i = rho t_i (rho the
// readout, t the rows' times times their side's rate):
//
//     reference row = a_r P_m,     observed row = P_i + a_i (P_n - P_i),
//
// so dr/dP_m = a_r dr/dref, dr/dP_i = (1 - a_i) dr/drow, dr/dP_n = a_i dr/drow
// and dr/drho = t_r dr/dref P_m + t_i dr/drow (P_n - P_i).
// RollingShutterReprojectionError::Evaluate is the readable reference the
// tests hold this Jacobian to.
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
