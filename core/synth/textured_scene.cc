#include "core/synth/textured_scene.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>

#include "core/io/burst.h"
#include "core/io/image_decode.h"

namespace dfsm {
namespace {

// Photographs from Debian's opencv-doc with texture at every scale (foliage,
// fur, brickwork, graffiti). Flat ones (logos, charts) are left out: a surface
// without texture has no depth to recover.
constexpr const char* kPhotographs[] = {"baboon.jpg", "graf1.png",        "fruits.jpg",
                                        "home.jpg",   "building.jpg",     "aloeL.jpg",
                                        "stuff.jpg",  "starry_night.jpg", "orange.jpg"};

// Index into [0, n) of texel i under mirrored repetition (period 2n, seamless).
inline int MirroredIndex(int i, int n) {
  const int period = 2 * n;
  int m = i % period;
  if (m < 0) m += period;
  return m < n ? m : period - 1 - m;
}

Eigen::Matrix3d RotationXYZ(double ax, double ay, double az) {
  return (Eigen::AngleAxisd(az, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(ay, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(ax, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

}  // namespace

cv::Mat ProceduralTexture(std::mt19937_64* rng) {
  constexpr int kSize = 512;
  cv::Mat texture(kSize, kSize, CV_32FC3, cv::Scalar::all(0.0));
  cv::RNG cv_rng((*rng)());
  double amplitude = 1.0, total = 0.0;
  for (int cells = 4; cells <= kSize; cells *= 2) {
    cv::Mat octave(cells, cells, CV_32FC3);
    cv_rng.fill(octave, cv::RNG::UNIFORM, cv::Scalar::all(0.0), cv::Scalar::all(1.0));
    cv::resize(octave, octave, texture.size(), 0, 0, cv::INTER_CUBIC);
    texture += octave * amplitude;
    total += amplitude;
    amplitude *= 0.75;
  }
  texture *= 255.0 / total;
  cv::normalize(texture, texture, 0.0, 255.0, cv::NORM_MINMAX);
  return texture;
}

cv::Vec3f SampleMirrored(const cv::Mat& texture, double x, double y) {
  const double x_floor = std::floor(x), y_floor = std::floor(y);
  const float fx = static_cast<float>(x - x_floor), fy = static_cast<float>(y - y_floor);
  const int x0 = static_cast<int>(x_floor), y0 = static_cast<int>(y_floor);
  const int c0 = MirroredIndex(x0, texture.cols), c1 = MirroredIndex(x0 + 1, texture.cols);
  const int r0 = MirroredIndex(y0, texture.rows), r1 = MirroredIndex(y0 + 1, texture.rows);
  const cv::Vec3f* row0 = texture.ptr<cv::Vec3f>(r0);
  const cv::Vec3f* row1 = texture.ptr<cv::Vec3f>(r1);
  return (row0[c0] * (1.0f - fx) + row0[c1] * fx) * (1.0f - fy) +
         (row1[c0] * (1.0f - fx) + row1[c1] * fx) * fy;
}

double TexturedPlane::Intersect(const Eigen::Vector3d& centre,
                                const Eigen::Vector3d& direction) const {
  const double denominator = normal.dot(direction);
  if (std::abs(denominator) < 1e-12) return -1.0;
  const double lambda = normal.dot(origin - centre) / denominator;
  if (lambda <= 0.0) return -1.0;
  const Eigen::Vector3d offset = centre + lambda * direction - origin;
  if (std::abs(offset.dot(axis_s)) > half_extent_s || std::abs(offset.dot(axis_t)) > half_extent_t)
    return -1.0;
  return lambda;
}

cv::Vec3f TexturedPlane::Sample(const Eigen::Vector3d& point) const {
  const Eigen::Vector3d offset = point - origin;
  return SampleMirrored(texture, offset.dot(axis_s) / texel_m + 0.5 * texture.cols,
                        offset.dot(axis_t) / texel_m + 0.5 * texture.rows);
}

TexturedScene::TexturedScene(const SceneOptions& options) {
  std::mt19937_64 rng(options.seed * 0xD1B54A32D192ED03ULL + 3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);

  std::vector<std::string> names(std::begin(kPhotographs), std::end(kPhotographs));
  std::shuffle(names.begin(), names.end(), rng);
  std::vector<cv::Mat> photographs;
  std::vector<std::string> photograph_names;
  for (const std::string& name : names) {
    const std::filesystem::path path = std::filesystem::path(options.texture_dir) / name;
    if (options.texture_dir.empty() || !std::filesystem::exists(path)) continue;
    cv::Mat image;
    try {
      image = ToBgr8(ReadImageFile(path));
    } catch (const std::runtime_error&) {
      continue;  // not a photograph this reader takes: the procedural textures stand in
    }
    image.convertTo(image, CV_32FC3);
    photographs.push_back(image);
    photograph_names.push_back(name);
  }
  auto next_texture = [&](int index, std::string* name) {
    if (photographs.empty()) {
      *name = "procedural";
      return ProceduralTexture(&rng);
    }
    *name = photograph_names[index % photographs.size()];
    return photographs[index % photographs.size()];
  };

  const double pixel_angle = 1.0 / options.f;  // radians per pixel at the centre
  const double infinite = std::numeric_limits<double>::infinity();

  // The background: an unbounded plane at far_depth, turned ~10 deg so that its
  // depth varies across the image.
  {
    TexturedPlane background;
    const Eigen::Matrix3d tilt =
        RotationXYZ(0.10 * (unit(rng) - 0.5), 0.35 * (unit(rng) - 0.5) + 0.15, 0.0);
    background.origin = Eigen::Vector3d(0.0, 0.0, options.far_depth);
    background.axis_s = tilt.col(0);
    background.axis_t = tilt.col(1);
    background.normal = tilt.col(2);
    background.half_extent_s = background.half_extent_t = infinite;
    background.texel_m = 1.2 * options.far_depth * pixel_angle;
    std::string name;
    background.texture = next_texture(0, &name);
    planes_.push_back(background);
    texture_names_.push_back(name);
  }

  // Patches spread evenly in inverse depth between near_depth and 0.7 far_depth,
  // at random places of the view, slanted by up to 35 deg.
  const double near_w = 1.0 / options.near_depth, far_w = 1.0 / (0.7 * options.far_depth);
  for (int k = 0; k < options.patches; ++k) {
    const double share = options.patches > 1 ? static_cast<double>(k) / (options.patches - 1) : 0;
    const double depth = 1.0 / (far_w + (near_w - far_w) * share);
    const double u = options.width * (0.15 + 0.7 * unit(rng));
    const double v = options.height * (0.15 + 0.7 * unit(rng));
    TexturedPlane patch;
    patch.origin = Eigen::Vector3d((u - 0.5 * options.width) * pixel_angle * depth,
                                   (v - 0.5 * options.height) * pixel_angle * depth, depth);
    const double slant = 35.0 * M_PI / 180.0;
    const Eigen::Matrix3d orientation = RotationXYZ(
        slant * (2.0 * unit(rng) - 1.0), slant * (2.0 * unit(rng) - 1.0), M_PI * unit(rng));
    patch.axis_s = orientation.col(0);
    patch.axis_t = orientation.col(1);
    patch.normal = orientation.col(2);
    const double view_width = options.width * pixel_angle * depth;
    patch.half_extent_s = view_width * (0.10 + 0.10 * unit(rng));
    patch.half_extent_t = view_width * (0.08 + 0.08 * unit(rng));
    patch.texel_m = depth * pixel_angle;
    std::string name;
    patch.texture = next_texture(k + 1, &name);
    planes_.push_back(patch);
    texture_names_.push_back(name);
  }

  // What follows draws from its own random streams, so that a scene without
  // it is the scene it always was.
  if (options.untextured > 0.0 && options.patches > 0) {
    const int flat = std::clamp(static_cast<int>(std::lround(options.untextured * options.patches)),
                                1, options.patches);
    std::vector<int> order(options.patches);
    for (int k = 0; k < options.patches; ++k) order[k] = k + 1;
    std::mt19937_64 flat_rng(options.seed * 0xE7037ED1A0B428DBULL + 5);
    std::shuffle(order.begin(), order.end(), flat_rng);
    for (int k = 0; k < flat; ++k) {
      TexturedPlane& patch = planes_[order[k]];
      // Whole grey levels: the 8-bit frames show exactly one colour.
      cv::Scalar mean = cv::mean(patch.texture);
      for (int c = 0; c < 3; ++c) mean[c] = std::round(mean[c]);
      patch.texture = cv::Mat(2, 2, CV_32FC3, mean);
      texture_names_[order[k]] = "flat";
      flat_patches_.push_back(order[k]);
    }
    std::sort(flat_patches_.begin(), flat_patches_.end());
  }
  if (options.curved_surfaces > 0) {
    CurvedSurfaceOptions curved;
    curved.count = options.curved_surfaces;
    curved.width = options.width;
    curved.height = options.height;
    curved.f = options.f;
    curved.near_depth = options.near_depth;
    curved.far_depth = options.far_depth;
    curved.seed = options.seed;
    curved_ = MakeCurvedSurfaces(curved, photographs);
    for (int k = 0; k < options.curved_surfaces; ++k)  // as MakeCurvedSurfaces picks them
      texture_names_.push_back(
          photographs.empty() ? "procedural" : photograph_names[(k + 1) % photograph_names.size()]);
  }
}

bool TexturedScene::Trace(const Eigen::Vector3d& centre, const Eigen::Vector3d& direction,
                          double* distance, cv::Vec3f* bgr) const {
  const TexturedPlane* nearest = nullptr;
  double nearest_lambda = std::numeric_limits<double>::infinity();
  for (const TexturedPlane& plane : planes_) {
    const double lambda = plane.Intersect(centre, direction);
    if (lambda > 0.0 && lambda < nearest_lambda) {
      nearest_lambda = lambda;
      nearest = &plane;
    }
  }
  const TexturedCurvedSurface* nearest_curved = nullptr;
  for (const TexturedCurvedSurface& surface : curved_) {
    const double lambda = surface.Intersect(centre, direction);
    if (lambda > 0.0 && lambda < nearest_lambda) {
      nearest_lambda = lambda;
      nearest_curved = &surface;
    }
  }
  if (nearest_curved != nullptr) {
    *distance = nearest_lambda;
    *bgr = nearest_curved->Sample(centre + nearest_lambda * direction);
    return true;
  }
  if (nearest == nullptr) return false;
  *distance = nearest_lambda;
  *bgr = nearest->Sample(centre + nearest_lambda * direction);
  return true;
}

}  // namespace dfsm
