#include "core/synth/moving_object.h"

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "core/synth/textured_scene.h"

namespace dfsm {

MovingObject::MovingObject(const MovingObjectOptions& options, const cv::Mat& texture) {
  // Its own random stream: the scene and the camera path stay as they were.
  std::mt19937_64 rng(options.seed * 0x9FB21C651E98DF25ULL + 41);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double pixel_angle = 1.0 / options.f;
  const double view_width = options.width * pixel_angle * options.depth;
  radius_ = 0.12 * view_width;
  texel_m_ = options.depth * pixel_angle;
  // Half-way through the burst the disc is somewhere in the middle half of
  // the view; it crosses it in a random direction.
  const double u = options.width * (0.25 + 0.5 * unit(rng));
  const double v = options.height * (0.25 + 0.5 * unit(rng));
  const double heading = 2.0 * M_PI * unit(rng);
  velocity_ = options.speed * view_width * Eigen::Vector3d(std::cos(heading), std::sin(heading), 0);
  const Eigen::Vector3d middle((u - 0.5 * options.width) * pixel_angle * options.depth,
                               (v - 0.5 * options.height) * pixel_angle * options.depth,
                               options.depth);
  centre0_ = middle - velocity_ * (0.5 * (options.frames - 1));
  // Facing the camera, tilted by up to 20 deg.
  const double tilt = 20.0 * M_PI / 180.0;
  const Eigen::Matrix3d orientation =
      (Eigen::AngleAxisd(2.0 * M_PI * unit(rng), Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(tilt * (2.0 * unit(rng) - 1.0), Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(tilt * (2.0 * unit(rng) - 1.0), Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  axis_s_ = orientation.col(0);
  axis_t_ = orientation.col(1);
  normal_ = orientation.col(2);
  texture_ = texture.empty() ? ProceduralTexture(&rng) : texture;
}

double MovingObject::Intersect(const Eigen::Vector3d& ray_centre, const Eigen::Vector3d& direction,
                               double t) const {
  const double denominator = normal_.dot(direction);
  if (std::abs(denominator) < 1e-12) return -1.0;
  const Eigen::Vector3d centre = CentreAt(t);
  const double lambda = normal_.dot(centre - ray_centre) / denominator;
  if (lambda <= 0.0) return -1.0;
  if ((ray_centre + lambda * direction - centre).squaredNorm() > radius_ * radius_) return -1.0;
  return lambda;
}

cv::Vec3f MovingObject::Sample(const Eigen::Vector3d& point, double t) const {
  const Eigen::Vector3d offset = point - CentreAt(t);
  return SampleMirrored(texture_, offset.dot(axis_s_) / texel_m_ + 0.5 * texture_.cols,
                        offset.dot(axis_t_) / texel_m_ + 0.5 * texture_.rows);
}

}  // namespace dfsm
