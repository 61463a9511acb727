// RowToRowResidual (rolling_shutter_reprojection_error.h) with its Jacobian
// written out by the chain rule: the part both row models' cost functions
// share (RollingShutterCostFunction, the line between frame poses;
// AngularVelocityCostFunction, each frame's own angular velocity). Each
// model's cost function maps the derivatives by the two row poses onto its
// own parameter blocks.
//
// Why not autodiff: the residual touches 23-29 parameters, and autodiff
// carries that many derivatives through every operation of the two rotations
// and both undistortions; the chain rule below needs a few 3x3 products
// (docs/experiments/118, 024). The maths, with the row poses
// {phi_ref, T_ref} and {Q_omega, Q_T}:
//
//     p  = undistort(u_ref; f, k1, k2),     P = (p, 1)
//     s  = P - w T_ref,                     wX = R(-phi_ref) s
//     X  = R(Q_omega) wX + w Q_T
//     r  = f (X_xy / X_z - undistort(u_obs; f, k1, k2))
//
// with d(R(phi) v)/d phi = -R(phi) [v]_x J_r(phi), J_r the right Jacobian of
// SO(3).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/sparse/rolling_shutter_reprojection_error.h"

namespace dfsm {

using RowPoseVector = Eigen::Matrix<double, 6, 1>;  // {angle-axis (3), T (3)}

// dr by each input of RowToRowResidual.
struct RowToRowDerivatives {
  Eigen::Matrix<double, 2, 3> intrinsics;          // f, k1, k2
  Eigen::Matrix<double, 2, 6> reference_row_pose;  // {phi_ref, T_ref}
  Eigen::Matrix<double, 2, 6> row_pose;            // {Q_omega, Q_T}
  Eigen::Vector2d inverse_depth;                   // w
};

// The residual of RowToRowResidual in doubles, and with `derivatives` its
// Jacobian by every input.
Eigen::Vector2d DifferentiateRowToRow(const double* intrinsics, double cx, double cy,
                                      const Eigen::Vector2d& reference,
                                      const Eigen::Vector2d& observed, double w,
                                      const RowPoseVector& reference_row_pose,
                                      const RowPoseVector& row_pose,
                                      RowToRowDerivatives* derivatives);

// Copies one Jacobian block into Ceres' row-major storage, where Ceres asks
// for it (a null block is one held constant).
template <int kColumns>
void StoreJacobianBlock(const Eigen::Matrix<double, 2, kColumns>& jacobian, double* block) {
  using RowMajor = Eigen::Matrix<double, 2, kColumns, kColumns == 1 ? 0 : Eigen::RowMajor>;
  if (block) Eigen::Map<RowMajor>{block} = jacobian;
}

// The sizes of the blocks both row models' cost functions begin with
// (ReferenceNeighbourBlock): {3, 6, 6}, and 6 more with kOwnBlock.
std::vector<int32_t> IntrinsicsAndPoseBlockSizes(
    RollingShutterReprojectionError::ReferenceNeighbour shared);

// Stores dr by the intrinsics and by those pose blocks where Ceres asks; the
// reference neighbour's derivative goes to its own block, or is added to the
// block it shares (a block in two roles takes both derivatives).
void StoreIntrinsicsAndPoseJacobians(RollingShutterReprojectionError::ReferenceNeighbour shared,
                                     const Eigen::Matrix<double, 2, 3>& dr_dintrinsics,
                                     Eigen::Matrix<double, 2, 6> dr_dpose,
                                     Eigen::Matrix<double, 2, 6> dr_dneighbour,
                                     const Eigen::Matrix<double, 2, 6>& dr_dreference_neighbour,
                                     double** jacobians);

}  // namespace dfsm
