#include "core/synth/camera_path.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace dfsm {
namespace {

// A smooth random curve through the origin at s = 0: a sum of two sinusoids per
// axis with random frequencies (0.3 to 1.2 cycles over the burst) and phases.
class SmoothWander {
 public:
  explicit SmoothWander(std::mt19937_64* rng) {
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

}  // namespace

std::vector<Pose> HandheldCameraPath(const CameraPathOptions& options) {
  std::mt19937_64 rng(options.seed * 0x9E3779B97F4A7C15ULL + 17);
  const SmoothWander position(&rng), orientation(&rng);
  const int n = options.frames;
  std::vector<Eigen::Vector3d> centres(n), angles(n);
  for (int i = 0; i < n; ++i) {
    const double s = n > 1 ? static_cast<double>(i) / (n - 1) : 0.0;
    centres[i] = position.At(s);
    centres[i].z() *= options.forward_fraction;
    angles[i] = orientation.At(s);
  }
  // Scale to the requested extents: the widest pair of centres spans the
  // baseline, the largest rotation is rotation_deg.
  double widest = 0.0, largest_angle = 0.0;
  for (int i = 0; i < n; ++i) {
    largest_angle = std::max(largest_angle, angles[i].norm());
    for (int j = i + 1; j < n; ++j) widest = std::max(widest, (centres[i] - centres[j]).norm());
  }
  const double position_scale = widest > 0.0 ? options.baseline / widest : 0.0;
  const double angle_scale =
      largest_angle > 0.0 ? options.rotation_deg * M_PI / 180.0 / largest_angle : 0.0;

  std::vector<Pose> poses(n);
  for (int i = 1; i < n; ++i) {
    const Eigen::Vector3d angle = angles[i] * angle_scale;
    const Eigen::Vector3d centre = centres[i] * position_scale;
    poses[i].R = angle.norm() > 0.0
                     ? Eigen::AngleAxisd(angle.norm(), angle.normalized()).toRotationMatrix()
                     : Eigen::Matrix3d::Identity();
    poses[i].T = -poses[i].R * centre;
  }
  return poses;
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
