#include "core/synth/curved_surfaces.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "core/synth/textured_scene.h"

namespace dfsm {
namespace {

// Roots of A l^2 + B l + C = 0, smallest first; false without real roots.
bool SolveQuadratic(double a, double b, double c, double* l0, double* l1) {
  if (std::abs(a) < 1e-300) return false;
  const double discriminant = b * b - 4.0 * a * c;
  if (discriminant < 0.0) return false;
  // The numerically stable form: q = -(b + sign(b) sqrt(D)) / 2.
  const double q = -0.5 * (b + std::copysign(std::sqrt(discriminant), b));
  double r0 = q / a, r1 = q != 0.0 ? c / q : r0;
  if (r0 > r1) std::swap(r0, r1);
  *l0 = r0;
  *l1 = r1;
  return true;
}

}  // namespace

double TexturedCurvedSurface::Intersect(const Eigen::Vector3d& ray_centre,
                                        const Eigen::Vector3d& direction) const {
  const Eigen::Vector3d offset = ray_centre - centre;
  double l0, l1;
  if (kind == Kind::kSphere) {
    if (!SolveQuadratic(direction.squaredNorm(), 2.0 * offset.dot(direction),
                        offset.squaredNorm() - radius * radius, &l0, &l1))
      return -1.0;
    return l0 > 0.0 ? l0 : (l1 > 0.0 ? l1 : -1.0);
  }
  // Cylinder: the components across the axis.
  const Eigen::Vector3d d_across = direction - direction.dot(axis) * axis;
  const Eigen::Vector3d o_across = offset - offset.dot(axis) * axis;
  if (!SolveQuadratic(d_across.squaredNorm(), 2.0 * o_across.dot(d_across),
                      o_across.squaredNorm() - radius * radius, &l0, &l1))
    return -1.0;
  for (const double lambda : {l0, l1}) {
    if (lambda <= 0.0) continue;
    if (std::abs((offset + lambda * direction).dot(axis)) <= half_length) return lambda;
  }
  return -1.0;
}

cv::Vec3f TexturedCurvedSurface::Sample(const Eigen::Vector3d& point) const {
  const Eigen::Vector3d p = point - centre;
  const double along = p.dot(axis);
  const double azimuth = std::atan2(p.dot(e2), p.dot(e1));  // 0 facing the camera
  double s, t;
  if (kind == Kind::kSphere) {
    const double across = std::hypot(p.dot(e1), p.dot(e2));
    s = radius * azimuth;
    t = radius * std::atan2(along, across);
  } else {
    s = radius * azimuth;
    t = along;
  }
  return SampleMirrored(texture, s / texel_m + 0.5 * texture.cols,
                        t / texel_m + 0.5 * texture.rows);
}

double TexturedCurvedSurface::Residual(const Eigen::Vector3d& point) const {
  const Eigen::Vector3d p = point - centre;
  if (kind == Kind::kSphere) return p.norm() - radius;
  return (p - p.dot(axis) * axis).norm() - radius;
}

std::vector<TexturedCurvedSurface> MakeCurvedSurfaces(const CurvedSurfaceOptions& options,
                                                      const std::vector<cv::Mat>& textures) {
  // Its own random stream: the planes of the scene stay where they were.
  std::mt19937_64 rng(options.seed * 0xA24BAED4963EE407ULL + 29);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double pixel_angle = 1.0 / options.f;
  const double near_w = 1.0 / options.near_depth, far_w = 1.0 / (0.7 * options.far_depth);
  std::vector<TexturedCurvedSurface> surfaces;
  for (int k = 0; k < options.count; ++k) {
    const double share = options.count > 1 ? static_cast<double>(k) / (options.count - 1) : 0.5;
    const double depth = 1.0 / (far_w + (near_w - far_w) * (0.15 + 0.7 * share));
    const double u = options.width * (0.15 + 0.7 * unit(rng));
    const double v = options.height * (0.2 + 0.6 * unit(rng));
    const double view_width = options.width * pixel_angle * depth;
    TexturedCurvedSurface surface;
    surface.kind =
        k % 2 == 0 ? TexturedCurvedSurface::Kind::kCylinder : TexturedCurvedSurface::Kind::kSphere;
    surface.radius = view_width * (0.06 + 0.05 * unit(rng));
    // The centre lies one radius behind the depth, so the front is at `depth`.
    const Eigen::Vector3d ray((u - 0.5 * options.width) * pixel_angle,
                              (v - 0.5 * options.height) * pixel_angle, 1.0);
    surface.centre = ray * depth + ray.normalized() * surface.radius;
    // A roughly upright axis, tilted by up to 25 deg.
    const double tilt = 25.0 * M_PI / 180.0;
    surface.axis = (Eigen::AngleAxisd(tilt * (2.0 * unit(rng) - 1.0), Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(tilt * (2.0 * unit(rng) - 1.0), Eigen::Vector3d::UnitX()) *
                    Eigen::Vector3d::UnitY())
                       .normalized();
    const Eigen::Vector3d towards_camera = -surface.centre;
    surface.e1 = (towards_camera - towards_camera.dot(surface.axis) * surface.axis).normalized();
    surface.e2 = surface.axis.cross(surface.e1);
    surface.half_length = options.height * pixel_angle * depth * (0.2 + 0.15 * unit(rng));
    surface.texel_m = depth * pixel_angle;
    if (textures.empty()) {
      surface.texture = ProceduralTexture(&rng);
    } else {
      surface.texture = textures[(k + 1) % textures.size()];
    }
    surfaces.push_back(surface);
  }
  return surfaces;
}

}  // namespace dfsm
