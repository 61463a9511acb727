// The 3-D scene of a synthetic burst: textured planar patches (slanted
// rectangles at several depths) in front of an unbounded background plane,
// optionally curved surfaces (cylinders, spheres) and patches of flat colour,
// all in reference-camera coordinates (metres).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/synth/curved_surfaces.h"

namespace dfsm {

// Bilinear lookup of a CV_32FC3 texture at texel coordinates (x, y) under
// mirrored repetition (seamless at any extent).
cv::Vec3f SampleMirrored(const cv::Mat& texture, double x, double y);

// Multi-octave value noise in colour (512 x 512, CV_32FC3 in [0, 255]): the
// fallback where no photograph exists. Draws one number from `rng`.
cv::Mat ProceduralTexture(std::mt19937_64* rng);

// A planar patch: points origin + s * axis_s + t * axis_t with |s| <= half_extent_s
// and |t| <= half_extent_t (infinite extents for the background). The texture
// repeats mirrored, so a patch of any size is covered without seams.
struct TexturedPlane {
  Eigen::Vector3d origin;
  Eigen::Vector3d axis_s, axis_t;  // orthonormal, in the plane
  Eigen::Vector3d normal;          // axis_s x axis_t
  double half_extent_s = 0.0, half_extent_t = 0.0;
  double texel_m = 0.001;  // size of one texture pixel on the plane
  cv::Mat texture;         // CV_32FC3, BGR in [0, 255]

  // Distance along the ray (centre + lambda * direction) to the patch, or a
  // negative value when the ray misses it.
  double Intersect(const Eigen::Vector3d& centre, const Eigen::Vector3d& direction) const;
  // Bilinear, mirrored-repeat texture lookup at a point of the plane.
  cv::Vec3f Sample(const Eigen::Vector3d& point) const;
};

struct SceneOptions {
  int width = 1920, height = 1080;
  double f = 2100.0;
  double near_depth = 0.9, far_depth = 4.0;  // patch depths span [near, far); background at far
  int patches = 4;
  // Large untextured regions: this share of the patches (rounded, at least one
  // above 0) is a flat colour, the mean of its texture (0: none).
  double untextured = 0.0;
  int curved_surfaces = 0;  // cylinders and spheres (curved_surfaces.h) among the patches
  uint64_t seed = 1;
  std::string texture_dir;  // photographs; procedural textures where none is found
};

class TexturedScene {
 public:
  explicit TexturedScene(const SceneOptions& options);

  // The nearest surface along a ray: its distance and colour. Every ray from a
  // camera near the reference hits the background, so this always succeeds for
  // the rays a burst renders.
  bool Trace(const Eigen::Vector3d& centre, const Eigen::Vector3d& direction, double* distance,
             cv::Vec3f* bgr) const;

  const std::vector<TexturedPlane>& planes() const { return planes_; }
  const std::vector<TexturedCurvedSurface>& curved_surfaces() const { return curved_; }
  // Indices into planes() of the patches of flat colour.
  const std::vector<int>& flat_patches() const { return flat_patches_; }
  // Names of the photographs used ("procedural" for generated textures,
  // "flat" for a patch of flat colour): the planes', then the curved surfaces'.
  const std::vector<std::string>& texture_names() const { return texture_names_; }

 private:
  std::vector<TexturedPlane> planes_;  // [0] is the background
  std::vector<std::string> texture_names_;
  std::vector<TexturedCurvedSurface> curved_;
  std::vector<int> flat_patches_;
};

}  // namespace dfsm
