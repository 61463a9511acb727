#include "core/sparse/angular_velocity_cost_function.h"

#include "core/sparse/row_to_row_jacobian.h"

namespace dfsm {

using Matrix26 = Eigen::Matrix<double, 2, 6>;

AngularVelocityCostFunction::AngularVelocityCostFunction(
    const AngularVelocityReprojectionError& error, ReferenceNeighbour shared)
    : error_(error), shared_(shared) {
  set_num_residuals(2);
  std::vector<int32_t>& sizes = *mutable_parameter_block_sizes();
  sizes = IntrinsicsAndPoseBlockSizes(shared);
  for (const int size : {3, 3, 1, 1}) sizes.push_back(size);
}

bool AngularVelocityCostFunction::Evaluate(double const* const* parameters, double* residuals,
                                           double** jacobians) const {
  const int next = BlockAfterPoses(shared_);
  const Eigen::Map<const RowPoseVector> pose(parameters[1]);
  const Eigen::Map<const RowPoseVector> neighbour(parameters[2]);
  const Eigen::Map<const RowPoseVector> reference_neighbour(
      ReferenceNeighbourBlock(parameters, shared_));
  const Eigen::Map<const Eigen::Vector3d> velocity(parameters[next]);
  const Eigen::Map<const Eigen::Vector3d> reference_velocity(parameters[next + 1]);
  const double w = parameters[next + 2][0];
  const double readout = parameters[next + 3][0];
  const double dt_r = readout * error_.reference_row_;
  const double dt_i = readout * error_.frame_row_;
  const double s_r = error_.reference_rate_, s_i = error_.frame_rate_;
  const Eigen::Vector3d m_T = reference_neighbour.tail<3>();
  const Eigen::Vector3d step_T = neighbour.tail<3>() - pose.tail<3>();
  RowPoseVector reference_row_pose, row_pose;
  reference_row_pose << dt_r * reference_velocity, dt_r * s_r * m_T;
  row_pose << pose.head<3>() + dt_i * velocity, pose.tail<3>() + dt_i * s_i * step_T;
  RowToRowDerivatives d;
  Eigen::Map<Eigen::Vector2d>{residuals} = DifferentiateRowToRow(
      parameters[0], error_.cx_, error_.cy_, error_.reference_, error_.observed_, w,
      reference_row_pose, row_pose, jacobians ? &d : nullptr);
  if (!jacobians) return true;

  const auto dr_dref_omega = d.reference_row_pose.leftCols<3>();
  const auto dr_dref_T = d.reference_row_pose.rightCols<3>();
  const auto dr_drow_omega = d.row_pose.leftCols<3>();
  const auto dr_drow_T = d.row_pose.rightCols<3>();
  Matrix26 dr_dpose, dr_dneighbour, dr_dreference_neighbour;
  dr_dpose << dr_drow_omega, (1.0 - dt_i * s_i) * dr_drow_T;
  dr_dneighbour << Eigen::Matrix<double, 2, 3>::Zero(), dt_i * s_i * dr_drow_T;
  dr_dreference_neighbour << Eigen::Matrix<double, 2, 3>::Zero(), dt_r * s_r * dr_dref_T;
  const Eigen::Vector2d dr_dreadout =
      error_.reference_row_ * (dr_dref_omega * reference_velocity + s_r * dr_dref_T * m_T) +
      error_.frame_row_ * (dr_drow_omega * velocity + s_i * dr_drow_T * step_T);
  StoreIntrinsicsAndPoseJacobians(shared_, d.intrinsics, dr_dpose, dr_dneighbour,
                                  dr_dreference_neighbour, jacobians);
  StoreJacobianBlock<3>(Eigen::Matrix<double, 2, 3>(dt_i * dr_drow_omega), jacobians[next]);
  StoreJacobianBlock<3>(Eigen::Matrix<double, 2, 3>(dt_r * dr_dref_omega), jacobians[next + 1]);
  StoreJacobianBlock<1>(d.inverse_depth, jacobians[next + 2]);
  StoreJacobianBlock<1>(dr_dreadout, jacobians[next + 3]);
  return true;
}

}  // namespace dfsm
