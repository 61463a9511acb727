#include "core/camera/camera_model.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

namespace dfsm {

CameraModel CameraModel::Initial(int width, int height) {
  CameraModel camera;
  camera.width = width;
  camera.height = height;
  camera.f = std::max(width, height);
  camera.cx = width / 2.0;
  camera.cy = height / 2.0;
  return camera;
}

Eigen::Vector2d CameraModel::PixelToUndistorted(const Eigen::Vector2d& pixel) const {
  Eigen::Vector2d x_u;
  dfsm::PixelToUndistorted(f, k1, k2, cx, cy, pixel.x(), pixel.y(), &x_u.x(), &x_u.y());
  return x_u;
}

std::optional<Eigen::Vector2d> CameraModel::UndistortedToPixel(const Eigen::Vector2d& x_u) const {
  const double r_u = x_u.norm();
  if (r_u < 1e-15) return Eigen::Vector2d(cx, cy);
  // Solve r_d * (1 + k1 r_d^2 + k2 r_d^4) = r_u for r_d, starting from r_u.
  double r = r_u;
  for (int iteration = 0; iteration < 50; ++iteration) {
    const double r2 = r * r;
    const double g = r * RadialFactor(k1, k2, r2) - r_u;
    const double dg = 1.0 + 3.0 * k1 * r2 + 5.0 * k2 * r2 * r2;
    if (dg <= 1e-6) return std::nullopt;
    const double step = g / dg;
    r -= step;
    if (r <= 0.0) return std::nullopt;
    if (std::abs(step) < 1e-14 * std::max(1.0, r)) break;
  }
  const double r2 = r * r;
  if (std::abs(r * RadialFactor(k1, k2, r2) - r_u) > 1e-9 * std::max(1.0, r_u)) return std::nullopt;
  // The derivative must stay positive along [0, r]: otherwise the root lies past a fold.
  if (1.0 + 3.0 * k1 * r2 + 5.0 * k2 * r2 * r2 <= 0.0) return std::nullopt;
  const Eigen::Vector2d x_d = x_u * (r / r_u);
  return Eigen::Vector2d(f * x_d.x() + cx, f * x_d.y() + cy);
}

double MeanDistortionError(const CameraModel& estimated, const CameraModel& truth, int step,
                           int* failed) {
  double sum = 0.0;
  int count = 0;
  int bad = 0;
  for (int v = 0; v < truth.height; v += step) {
    for (int u = 0; u < truth.width; u += step) {
      const Eigen::Vector2d pixel(u, v);
      const Eigen::Vector2d x_u = estimated.PixelToUndistorted(pixel);
      // Express the estimated undistorted point in the true camera's normalized
      // frame: both models share the ideal pinhole of their own f, so compare
      // through the pixel grid of the undistorted image.
      const Eigen::Vector2d x_u_truth =
          (estimated.UndistortedToIdealPixel(x_u) - Eigen::Vector2d(truth.cx, truth.cy)) / truth.f;
      const auto back = truth.UndistortedToPixel(x_u_truth);
      if (!back) {
        ++bad;
        continue;
      }
      sum += (*back - pixel).norm();
      ++count;
    }
  }
  if (failed) *failed = bad;
  return count > 0 ? sum / count : 0.0;
}

nlohmann::json ToJson(const CameraModel& camera) {
  return {{"width", camera.width},
          {"height", camera.height},
          {"fx", camera.f},
          {"fy", camera.f},
          {"cx", camera.cx},
          {"cy", camera.cy},
          {"k1", camera.k1},
          {"k2", camera.k2},
          {"distortion_model", kDistortionModelName}};
}

namespace {
double RequireNumber(const nlohmann::json& j, const char* key) {
  if (!j.contains(key) || !j[key].is_number())
    throw std::runtime_error(std::string("calibration: field '") + key +
                             "' missing or not a number");
  return j[key].get<double>();
}
}  // namespace

CameraModel CameraModelFromJson(const nlohmann::json& j) {
  if (!j.is_object()) throw std::runtime_error("calibration: not a JSON object");
  if (j.contains("distortion_model") && j["distortion_model"] != kDistortionModelName)
    throw std::runtime_error("calibration: distortion_model " +
                             (j["distortion_model"].is_string()
                                  ? "'" + j["distortion_model"].get<std::string>() + "'"
                                  : std::string("(not a string)")) +
                             " is not '" + kDistortionModelName + "'");
  CameraModel camera;
  camera.width = static_cast<int>(RequireNumber(j, "width"));
  camera.height = static_cast<int>(RequireNumber(j, "height"));
  const double fx = RequireNumber(j, "fx");
  const double fy = j.contains("fy") ? RequireNumber(j, "fy") : fx;
  if (std::abs(fx - fy) > 1e-6 * std::abs(fx))
    throw std::runtime_error("calibration: fx != fy, but the model has square pixels");
  camera.f = fx;
  camera.cx = RequireNumber(j, "cx");
  camera.cy = RequireNumber(j, "cy");
  camera.k1 = j.contains("k1") ? RequireNumber(j, "k1") : 0.0;
  camera.k2 = j.contains("k2") ? RequireNumber(j, "k2") : 0.0;
  if (camera.width <= 0 || camera.height <= 0 || !(camera.f > 0))
    throw std::runtime_error("calibration: width, height and fx must be positive");
  return camera;
}

}  // namespace dfsm
