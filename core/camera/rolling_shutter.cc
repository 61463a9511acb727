#include "core/camera/rolling_shutter.h"

#include <Eigen/Geometry>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace dfsm {
namespace {

// The whole text as a plain decimal number (no sign, blanks, inf or nan).
std::optional<double> ParseReadout(const std::string& text) {
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value, std::chars_format::fixed);
  if (text.empty() || error != std::errc() || stop != end || !std::isfinite(value))
    return std::nullopt;
  return value;
}

}  // namespace

PoseParameters ToPoseParameters(const Pose& pose) {
  const Eigen::AngleAxisd rotation(pose.R);
  PoseParameters parameters;
  parameters.head<3>() = rotation.angle() * rotation.axis();
  parameters.tail<3>() = pose.T;
  return parameters;
}

Pose FromPoseParameters(const PoseParameters& parameters) {
  Pose pose;
  const Eigen::Vector3d axis_angle = parameters.head<3>();
  const double angle = axis_angle.norm();
  if (angle > 0.0) pose.R = Eigen::AngleAxisd(angle, axis_angle / angle).toRotationMatrix();
  pose.T = parameters.tail<3>();
  return pose;
}

void RollingShutterOptions::Check() const {
  if (mode == Mode::kKnown && !(readout >= 0.0 && readout <= kMaxReadout))
    throw std::invalid_argument(
        "the rolling shutter readout must be in [0, 1] of the frame "
        "interval, got " +
        std::to_string(readout));
}

RollingShutterOptions ParseRollingShutter(const std::string& text) {
  RollingShutterOptions options;
  options.mode = RollingShutterOptions::Mode::kGlobal;
  if (text == "global") return options;
  if (text == "estimate") {
    options.mode = RollingShutterOptions::Mode::kEstimate;
    return options;
  }
  const std::optional<double> readout = ParseReadout(text);
  if (!readout)
    throw std::invalid_argument(
        "rolling shutter must be \"global\", \"estimate\" or a readout in [0, 1] of the frame "
        "interval, not \"" +
        text + "\"");
  options.mode =
      *readout == 0.0 ? RollingShutterOptions::Mode::kGlobal : RollingShutterOptions::Mode::kKnown;
  options.readout = *readout;
  options.Check();
  return options;
}

std::string RollingShutterName(const RollingShutterOptions& options) {
  switch (options.mode) {
    case RollingShutterOptions::Mode::kGlobal:
      return "global";
    case RollingShutterOptions::Mode::kEstimate:
      return "estimate";
    case RollingShutterOptions::Mode::kKnown:
      break;
  }
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", options.readout);
  return text;
}

void CheckFrameTimes(const std::vector<double>& times, int frames) {
  if (times.empty()) return;
  if (static_cast<int>(times.size()) != frames)
    throw std::invalid_argument("frame times: " + std::to_string(times.size()) + " times for " +
                                std::to_string(frames) + " frames");
  for (size_t i = 0; i < times.size(); ++i)
    if (!std::isfinite(times[i]) || (i > 0 && !(times[i] > times[i - 1])))
      throw std::invalid_argument("frame times: time " + std::to_string(i) +
                                  " is not finite or not after the one before");
}

Neighbour NeighbourOnSide(int frame, double dt, int frames, const std::vector<double>& times) {
  const bool later = dt >= 0.0 ? frame + 1 < frames : frame == 0;
  const int neighbour = later ? frame + 1 : frame - 1;
  if (times.empty()) return {neighbour, later ? 1.0 : -1.0};
  return {neighbour, 1.0 / (times[neighbour] - times[frame])};
}

PoseSteps::PoseSteps(const std::vector<Pose>& poses, const std::vector<double>& times) {
  const int n = static_cast<int>(poses.size());
  std::vector<PoseParameters> p(n);
  for (int i = 0; i < n; ++i) p[i] = ToPoseParameters(poses[i]);
  before_.assign(n, PoseParameters::Zero());
  after_.assign(n, PoseParameters::Zero());
  if (n < 2) return;
  // Both sides are derivatives per frame interval, so a row's pose is
  // p[i] + dt * step whatever the sign of dt.
  for (int i = 0; i < n; ++i) {
    const Neighbour after = NeighbourOnSide(i, 1.0, n, times),
                    before = NeighbourOnSide(i, -1.0, n, times);
    after_[i] = after.rate * (p[after.frame] - p[i]);
    before_[i] = before.rate * (p[before.frame] - p[i]);
  }
}

void CheckAngularVelocities(const AngularVelocities& velocities, int frames) {
  if (velocities.empty()) return;
  if (static_cast<int>(velocities.size()) != frames)
    throw std::invalid_argument("angular velocities: " + std::to_string(velocities.size()) +
                                " velocities for " + std::to_string(frames) + " frames");
  for (const Eigen::Vector3d& velocity : velocities)
    if (!velocity.allFinite()) throw std::invalid_argument("angular velocities: not finite");
}

RowPoses::RowPoses(const std::vector<Pose>& poses, double readout, int height,
                   const std::vector<double>& times, AngularVelocities velocities)
    : steps_(poses, times), velocities_(std::move(velocities)), readout_(readout), height_(height) {
  CheckAngularVelocities(velocities_, static_cast<int>(poses.size()));
  for (const Pose& pose : poses) poses_.push_back(ToPoseParameters(pose));
}

Pose RowPoses::At(int frame, double v) const {
  const double dt = RowTime(readout_, v, height_);
  PoseParameters row = poses_[frame] + dt * steps_.Step(frame, dt);
  if (!velocities_.empty()) row.head<3>() = poses_[frame].head<3>() + dt * velocities_[frame];
  return FromPoseParameters(row);
}

Pose RowPoses::Relative(int frame, double v, int reference, double v_ref) const {
  const Pose row = At(frame, v);
  if (readout_ == 0.0) return row;
  // X_row = R_row X_world + T_row and X_refrow = R_ref X_world + T_ref, so
  // X_row = R_row R_ref^T (X_refrow - T_ref) + T_row.
  const Pose ref = At(reference, v_ref);
  Pose relative;
  relative.R = row.R * ref.R.transpose();
  relative.T = row.T - relative.R * ref.T;
  return relative;
}

}  // namespace dfsm
