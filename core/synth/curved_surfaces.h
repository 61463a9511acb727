// Curved surfaces of a synthetic scene (issue 13: real scenes are not made of
// planes): textured cylinders and spheres, intersected in closed form so that
// the ground-truth depth stays exact.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

struct TexturedCurvedSurface {
  enum class Kind { kCylinder, kSphere };
  Kind kind = Kind::kCylinder;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // on the axis, half-way along it
  // Orthonormal frame: axis is the cylinder's (or the sphere's pole), e1 points
  // from the centre towards the reference camera (the texture's seam is behind).
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY(), e1 = -Eigen::Vector3d::UnitZ(),
                  e2 = Eigen::Vector3d::UnitX();
  double radius = 0.1;
  double half_length = 0.2;  // cylinder: |(X - centre) . axis| <= half_length (open tube)
  double texel_m = 0.001;
  cv::Mat texture;  // CV_32FC3, BGR in [0, 255]

  // Smallest positive distance along the ray (centre + lambda direction) to the
  // surface, or a negative value when the ray misses it.
  double Intersect(const Eigen::Vector3d& ray_centre, const Eigen::Vector3d& direction) const;
  // Texture at a point of the surface: arc length around the axis and height
  // along it (latitude arc for the sphere).
  cv::Vec3f Sample(const Eigen::Vector3d& point) const;
  // Signed distance of a point from the surface (0 on it): for tests.
  double Residual(const Eigen::Vector3d& point) const;
};

struct CurvedSurfaceOptions {
  int count = 0;  // alternately cylinder, sphere, cylinder, ...
  int width = 1920, height = 1080;
  double f = 2100.0;
  double near_depth = 0.9, far_depth = 4.0;
  uint64_t seed = 1;
};

// Surfaces spread in inverse depth between near_depth and 0.7 far_depth, in
// the middle 70 % of the view; surface k has textures[(k + 1) % size] (a
// procedural one where `textures` is empty). Deterministic for given options.
std::vector<TexturedCurvedSurface> MakeCurvedSurfaces(const CurvedSurfaceOptions& options,
                                                      const std::vector<cv::Mat>& textures);

}  // namespace dfsm
