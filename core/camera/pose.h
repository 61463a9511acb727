// Pose of a frame relative to the reference frame (CONTRACT.md section 1):
// X_i = R_i * X_ref + T_i. The reference frame has R = I, T = 0.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

namespace dfsm {

struct Pose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d T = Eigen::Vector3d::Zero();

  // Centre of this camera in reference coordinates.
  Eigen::Vector3d Centre() const { return -R.transpose() * T; }
  Eigen::Vector3d Transform(const Eigen::Vector3d& X_ref) const { return R * X_ref + T; }
};

// Angle in degrees of the rotation R_a^T R_b.
double RotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// {"R": [9, row-major], "T": [3]}; FromJson throws std::runtime_error on a bad shape.
nlohmann::json ToJson(const Pose& pose);
Pose PoseFromJson(const nlohmann::json& j);

}  // namespace dfsm
