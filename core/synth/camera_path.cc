#include "core/synth/camera_path.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>

namespace dfsm {

// A smooth random curve through the origin at s = 0: a sum of two sinusoids per
// axis with random frequencies (0.3 to 1.2 cycles over the burst) and phases.
class HandheldPath::Wander {
 public:
  explicit Wander(std::mt19937_64* rng) {
    std::uniform_real_distribution<double> frequency(0.3, 1.2), phase(0.0, 2.0 * M_PI),
        weight(0.5, 1.0);
    for (int axis = 0; axis < 3; ++axis)
      for (int k = 0; k < 2; ++k) terms_[axis][k] = {weight(*rng), frequency(*rng), phase(*rng)};
  }

  Eigen::Vector3d At(double s) const {
    Eigen::Vector3d value;
    for (int axis = 0; axis < 3; ++axis) {
      value[axis] = 0.0;
      for (const Term& term : terms_[axis])
        value[axis] += term.weight * (std::sin(2.0 * M_PI * term.frequency * s + term.phase) -
                                      std::sin(term.phase));
    }
    return value;
  }

 private:
  struct Term {
    double weight, frequency, phase;
  };
  Term terms_[3][2];
};

HandheldPath::HandheldPath(const CameraPathOptions& options) : options_(options) {
  std::mt19937_64 rng(options.seed * 0x9E3779B97F4A7C15ULL + 17);
  position_ = std::make_shared<const Wander>(&rng);
  orientation_ = std::make_shared<const Wander>(&rng);
  // Scale to the requested extents over the frames: the widest pair of
  // centres spans the baseline, the largest rotation is rotation_deg.
  const int n = options.frames;
  std::vector<Eigen::Vector3d> centres(n), angles(n);
  position_scale_ = angle_scale_ = 1.0;
  for (int i = 0; i < n; ++i) {
    centres[i] = Centre(i);
    angles[i] = orientation_->At(n > 1 ? static_cast<double>(i) / (n - 1) : 0.0);
  }
  double widest = 0.0, largest_angle = 0.0;
  for (int i = 0; i < n; ++i) {
    largest_angle = std::max(largest_angle, angles[i].norm());
    for (int j = i + 1; j < n; ++j) widest = std::max(widest, (centres[i] - centres[j]).norm());
  }
  position_scale_ = widest > 0.0 ? options.baseline / widest : 0.0;
  angle_scale_ = largest_angle > 0.0 ? options.rotation_deg * M_PI / 180.0 / largest_angle : 0.0;
  // Drawn after the wander, so that the wander is the same whatever the
  // oscillation.
  std::uniform_real_distribution<double> weight(0.5, 1.0), rate(0.8, 1.2), phase(0.0, 2.0 * M_PI);
  for (Oscillation& axis : oscillation_)
    axis = {options.oscillation_deg * M_PI / 180.0 * weight(rng),
            options.oscillation_cycles_per_frame * rate(rng), phase(rng)};
  frames_.resize(n);
  for (int i = 1; i < n; ++i) frames_[i] = HandAt(i);
}

Eigen::Vector3d HandheldPath::Centre(double t) const {
  const int n = options_.frames;
  Eigen::Vector3d centre = position_->At(n > 1 ? t / (n - 1) : 0.0);
  centre.z() *= options_.forward_fraction;
  return centre * position_scale_;
}

Eigen::Vector3d HandheldPath::Angles(double t) const {
  const int n = options_.frames;
  Eigen::Vector3d angles = orientation_->At(n > 1 ? t / (n - 1) : 0.0) * angle_scale_;
  for (int axis = 0; axis < 3; ++axis) {
    const Oscillation& o = oscillation_[axis];
    angles[axis] +=
        o.amplitude * (std::sin(2.0 * M_PI * o.cycles_per_frame * t + o.phase) - std::sin(o.phase));
  }
  return angles;
}

Pose HandheldPath::HandAt(double t) const {
  const Eigen::Vector3d angle = Angles(t);
  Pose pose;
  pose.R = angle.norm() > 0.0
               ? Eigen::AngleAxisd(angle.norm(), angle.normalized()).toRotationMatrix()
               : Eigen::Matrix3d::Identity();
  pose.T = -pose.R * Centre(t);
  return pose;
}

Pose HandheldPath::LineAt(double t) const {
  const int n = static_cast<int>(frames_.size());
  if (n == 1) return frames_[0];
  const int i = std::clamp(static_cast<int>(std::floor(t)), 0, n - 2);
  const double s = t - i;  // in [0, 1] between frames, beyond it at the ends
  const Pose& a = frames_[i];
  const Pose& b = frames_[i + 1];
  // Relative rotation a -> b as angle-axis, scaled by s.
  const Eigen::AngleAxisd step(b.R * a.R.transpose());
  Pose pose;
  pose.R = Eigen::AngleAxisd(s * step.angle(), step.axis()).toRotationMatrix() * a.R;
  pose.T = -pose.R * ((1.0 - s) * a.Centre() + s * b.Centre());
  return pose;
}

Pose HandheldPath::At(double t) const {
  if (t == std::floor(t) && t >= 0.0 && t < static_cast<double>(frames_.size()))
    return frames_[static_cast<size_t>(t)];
  return options_.between_frames == CameraPathOptions::BetweenFrames::kHand ? HandAt(t) : LineAt(t);
}

std::vector<Pose> HandheldPath::FramePoses() const { return frames_; }

std::vector<Pose> HandheldCameraPath(const CameraPathOptions& options) {
  return HandheldPath(options).FramePoses();
}

std::vector<Pose> PosesRelativeTo(const std::vector<Pose>& poses, int reference) {
  if (reference < 0 || reference >= static_cast<int>(poses.size()))
    throw std::invalid_argument("reference must be the index of one of the poses");
  const Pose& r = poses[reference];
  std::vector<Pose> relative(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    relative[i].R = poses[i].R * r.R.transpose();
    relative[i].T = poses[i].T - relative[i].R * r.T;
  }
  relative[reference] = Pose();  // exactly the identity, not a rounding of it
  return relative;
}

}  // namespace dfsm
