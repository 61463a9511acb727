#include "core/synth/camera_effects.h"

#include <Eigen/Geometry>
#include <cmath>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>

namespace dfsm {

void CameraEffects::Check() const {
  const auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(what);
  };
  require(rolling_shutter_readout >= 0.0 && rolling_shutter_readout <= 1.0,
          "rolling_shutter_readout must be between 0 and 1 of the frame interval");
  require(exposure_drift >= 0.0 && exposure_drift <= 0.5, "exposure_drift must be 0-0.5");
  require(white_balance_drift >= 0.0 && white_balance_drift <= 0.5,
          "white_balance_drift must be 0-0.5");
  require(vignetting >= 0.0 && vignetting <= 0.9, "vignetting must be 0-0.9");
}

bool CameraEffects::any() const {
  return rolling_shutter_readout > 0.0 || exposure_drift > 0.0 || white_balance_drift > 0.0 ||
         vignetting > 0.0;
}

CameraEffects CameraEffects::Preset(const std::string& name) {
  CameraEffects effects;
  if (name == "ideal") return effects;
  if (name == "webcam") {  // USB UVC: rolling shutter, slow auto exposure
    effects.rolling_shutter_readout = 0.8;
    effects.exposure_drift = 0.05;
    effects.white_balance_drift = 0.02;
    effects.vignetting = 0.2;
    return effects;
  }
  if (name == "phone") {  // the phone: readout 0.6, +-12 % exposure, 30 % vignetting
    effects.rolling_shutter_readout = 0.6;
    effects.exposure_drift = 0.12;
    effects.white_balance_drift = 0.03;
    effects.vignetting = 0.3;
    return effects;
  }
  throw std::invalid_argument("camera effects preset must be ideal, webcam or phone, not '" + name +
                              "'");
}

nlohmann::json ToJson(const CameraEffects& e) {
  return {{"rolling_shutter_readout", e.rolling_shutter_readout},
          {"exposure_drift", e.exposure_drift},
          {"white_balance_drift", e.white_balance_drift},
          {"vignetting", e.vignetting}};
}

Pose PoseAtTime(const std::vector<Pose>& poses, double t) {
  const int n = static_cast<int>(poses.size());
  if (n == 1) return poses[0];
  const int i = std::clamp(static_cast<int>(std::floor(t)), 0, n - 2);
  const double s = t - i;  // in [0, 1] between frames, beyond it at the ends
  const Pose& a = poses[i];
  const Pose& b = poses[i + 1];
  // Relative rotation a -> b as angle-axis, scaled by s.
  const Eigen::AngleAxisd step(b.R * a.R.transpose());
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(s * step.angle(), step.axis()).toRotationMatrix() * a.R;
  const Eigen::Vector3d centre = (1.0 - s) * a.Centre() + s * b.Centre();
  Pose pose;
  pose.R = R;
  pose.T = -R * centre;
  return pose;
}

void ApplyPhotometricEffects(const CameraEffects& effects, int frame_index, uint64_t seed,
                             cv::Mat* radiance) {
  std::mt19937_64 random(seed * 0x2545F4914F6CDD1DULL + static_cast<uint64_t>(frame_index) * 7919 +
                         3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double exposure = frame_index == 0 ? 1.0 : 1.0 + effects.exposure_drift * unit(random);
  cv::Vec3f gain;
  for (int c = 0; c < 3; ++c)
    gain[c] = static_cast<float>(
        exposure * (frame_index == 0 ? 1.0 : 1.0 + effects.white_balance_drift * unit(random)));
  const double cx = 0.5 * radiance->cols, cy = 0.5 * radiance->rows;
  const double corner2 = cx * cx + cy * cy;
  for (int v = 0; v < radiance->rows; ++v) {
    cv::Vec3f* row = radiance->ptr<cv::Vec3f>(v);
    for (int u = 0; u < radiance->cols; ++u) {
      const double r2 = ((u - cx) * (u - cx) + (v - cy) * (v - cy)) / corner2;
      const float falloff = static_cast<float>(1.0 - effects.vignetting * r2);
      for (int c = 0; c < 3; ++c) row[u][c] *= gain[c] * falloff;
    }
  }
}

}  // namespace dfsm
