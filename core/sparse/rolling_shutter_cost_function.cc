#include "core/sparse/rolling_shutter_cost_function.h"

#include "core/sparse/row_to_row_jacobian.h"

namespace dfsm {

RollingShutterCostFunction::RollingShutterCostFunction(const RollingShutterReprojectionError& error,
                                                       ReferenceNeighbour shared)
    : error_(error), shared_(shared) {
  set_num_residuals(2);
  std::vector<int32_t>& sizes = *mutable_parameter_block_sizes();
  sizes = IntrinsicsAndPoseBlockSizes(shared);
  sizes.push_back(1);
  sizes.push_back(1);
}

bool RollingShutterCostFunction::Evaluate(double const* const* parameters, double* residuals,
                                          double** jacobians) const {
  const int next = BlockAfterPoses(shared_);
  const Eigen::Map<const RowPoseVector> pose(parameters[1]);
  const Eigen::Map<const RowPoseVector> neighbour(parameters[2]);
  const Eigen::Map<const RowPoseVector> reference_neighbour(
      ReferenceNeighbourBlock(parameters, shared_));
  const double w = parameters[next][0];
  const double readout = parameters[next + 1][0];
  // The reference row's pose and the observed row's, on their lines.
  const double a_r = readout * error_.reference_row_;
  const double a_i = readout * error_.frame_row_;
  const RowPoseVector step = neighbour - pose;
  RowToRowDerivatives d;
  Eigen::Map<Eigen::Vector2d>{residuals} = DifferentiateRowToRow(
      parameters[0], error_.cx_, error_.cy_, error_.reference_, error_.observed_, w,
      a_r * reference_neighbour, pose + a_i * step, jacobians ? &d : nullptr);
  if (!jacobians) return true;

  const Eigen::Vector2d dr_dreadout =
      error_.reference_row_ * d.reference_row_pose * reference_neighbour +
      error_.frame_row_ * d.row_pose * step;
  StoreIntrinsicsAndPoseJacobians(shared_, d.intrinsics, (1.0 - a_i) * d.row_pose, a_i * d.row_pose,
                                  a_r * d.reference_row_pose, jacobians);
  StoreJacobianBlock<1>(d.inverse_depth, jacobians[next]);
  StoreJacobianBlock<1>(dr_dreadout, jacobians[next + 1]);
  return true;
}

}  // namespace dfsm
