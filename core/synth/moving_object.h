// A thing that moves on its own in front of a synthetic scene (issue 13: real
// footage has leaves and people that move between frames): a textured disc on
// a straight path at a constant speed, seen by every ray at its own time. Its
// pixels are recorded per frame (a mask and a box) so that a benchmark can
// exclude or score them; the reference depth shows it where each
// reference row saw it, at the row's time.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

struct MovingObjectOptions {
  // Speed across the image in fractions of its width per frame interval (0: no object).
  double speed = 0.0;
  int width = 1920, height = 1080;
  double f = 2100.0;
  double depth = 0.7;  // metres, in front of the nearest patch of the scene
  int frames = 10;
  uint64_t seed = 1;
};

class MovingObject {
 public:
  // `texture` CV_32FC3; a procedural texture where it is empty.
  MovingObject(const MovingObjectOptions& options, const cv::Mat& texture);

  // Distance along the ray (centre + lambda direction) to the disc at time t
  // (in frame intervals, 0 = the reference), or a negative value on a miss.
  double Intersect(const Eigen::Vector3d& ray_centre, const Eigen::Vector3d& direction,
                   double t) const;
  cv::Vec3f Sample(const Eigen::Vector3d& point, double t) const;
  Eigen::Vector3d CentreAt(double t) const { return centre0_ + velocity_ * t; }
  double radius() const { return radius_; }

 private:
  Eigen::Vector3d centre0_, velocity_;  // metres, metres per frame interval
  Eigen::Vector3d axis_s_, axis_t_, normal_;
  double radius_ = 0.0, texel_m_ = 0.001;
  cv::Mat texture_;
};

}  // namespace dfsm
