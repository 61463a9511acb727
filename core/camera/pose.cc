#include "core/camera/pose.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace dfsm {

double RotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const Eigen::AngleAxisd delta(a.transpose() * b);
  return std::abs(delta.angle()) * 180.0 / M_PI;
}

nlohmann::json ToJson(const Pose& pose) {
  nlohmann::json R = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R.push_back(pose.R(r, c));
  return {{"R", R}, {"T", {pose.T.x(), pose.T.y(), pose.T.z()}}};
}

Pose PoseFromJson(const nlohmann::json& j) {
  if (!j.is_object() || !j.contains("R") || !j.contains("T") || !j["R"].is_array() ||
      !j["T"].is_array() || j["R"].size() != 9 || j["T"].size() != 3)
    throw std::runtime_error("pose: expected {\"R\": [9 numbers], \"T\": [3 numbers]}");
  Pose pose;
  for (int k = 0; k < 9; ++k) pose.R(k / 3, k % 3) = j["R"][k].get<double>();
  for (int k = 0; k < 3; ++k) pose.T(k) = j["T"][k].get<double>();
  return pose;
}

}  // namespace dfsm
