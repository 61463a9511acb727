#include "core/sparse/rolling_shutter_cost_function.h"

#include "core/sparse/row_to_row_jacobian.h"

namespace dfsm {

RollingShutterCostFunction::RollingShutterCostFunction(const RollingShutterReprojectionError& error,
                                                       ReferenceNeighbour shared)
    : error_(error), shared_(shared) {
  set_num_residuals(2);
  std::vector<int32_t>& sizes = *mutable_parameter_block_sizes();
  sizes = {3, 6, 6};
  if (shared == ReferenceNeighbour::kOwnBlock) sizes.push_back(6);
  sizes.push_back(1);
  sizes.push_back(1);
}

bool RollingShutterCostFunction::Evaluate(double const* const* parameters, double* residuals,
                                          double** jacobians) const {
  const bool own = shared_ == ReferenceNeighbour::kOwnBlock;
  const Eigen::Map<const RowPoseVector> pose(parameters[1]);
  const Eigen::Map<const RowPoseVector> neighbour(parameters[2]);
  const Eigen::Map<const RowPoseVector> reference_neighbour(own ? parameters[3]
                                                            : shared_ == ReferenceNeighbour::kFrame
                                                                ? parameters[1]
                                                                : parameters[2]);
  const double w = parameters[own ? 4 : 3][0];
  const double readout = parameters[own ? 5 : 4][0];
  // The reference row's pose and the observed row's, on their lines.
  const double a_r = readout * error_.reference_row_;
  const double a_i = readout * error_.frame_row_;
  const RowPoseVector step = neighbour - pose;
  RowToRowDerivatives d;
  Eigen::Map<Eigen::Vector2d>{residuals} = DifferentiateRowToRow(
      parameters[0], error_.cx_, error_.cy_, error_.reference_, error_.observed_, w,
      a_r * reference_neighbour, pose + a_i * step, jacobians ? &d : nullptr);
  if (!jacobians) return true;

  Eigen::Matrix<double, 2, 6> dr_dpose = (1.0 - a_i) * d.row_pose;
  Eigen::Matrix<double, 2, 6> dr_dneighbour = a_i * d.row_pose;
  const Eigen::Matrix<double, 2, 6> dr_dreference_neighbour = a_r * d.reference_row_pose;
  const Eigen::Vector2d dr_dreadout =
      error_.reference_row_ * d.reference_row_pose * reference_neighbour +
      error_.frame_row_ * d.row_pose * step;
  // A block shared by two roles takes both derivatives.
  if (shared_ == ReferenceNeighbour::kFrame) dr_dpose += dr_dreference_neighbour;
  if (shared_ == ReferenceNeighbour::kFrameNeighbour) dr_dneighbour += dr_dreference_neighbour;
  StoreJacobianBlock<3>(d.intrinsics, jacobians[0]);
  StoreJacobianBlock<6>(dr_dpose, jacobians[1]);
  StoreJacobianBlock<6>(dr_dneighbour, jacobians[2]);
  if (own) StoreJacobianBlock<6>(dr_dreference_neighbour, jacobians[3]);
  StoreJacobianBlock<1>(d.inverse_depth, jacobians[own ? 4 : 3]);
  StoreJacobianBlock<1>(dr_dreadout, jacobians[own ? 5 : 4]);
  return true;
}

}  // namespace dfsm
