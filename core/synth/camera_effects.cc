#include "core/synth/camera_effects.h"

#include <Eigen/Geometry>
#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
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
  require(exposure_time >= 0.0 && exposure_time <= 1.0,
          "exposure_time (motion blur) must be between 0 and 1 of the frame interval");
  require(std::isfinite(k3) && std::abs(k3) <= 1.0, "k3 must be between -1 and 1");
  require(std::isfinite(p1) && std::abs(p1) <= 0.01 && std::isfinite(p2) && std::abs(p2) <= 0.01,
          "p1 and p2 (tangential distortion) must be between -0.01 and 0.01");
  require(shot_noise_gain == 0.0 || (shot_noise_gain >= 0.25 && shot_noise_gain <= 10000.0),
          "shot_noise_gain must be 0 (off) or 0.25-10000 electrons per grey level");
}

bool CameraEffects::any() const {
  return photometric() || rolling_shutter_readout > 0.0 || exposure_time > 0.0 || lens_extras() ||
         shot_noise_gain > 0.0 || bayer;
}

bool CameraEffects::photometric() const {
  return exposure_drift > 0.0 || white_balance_drift > 0.0 || vignetting > 0.0;
}

CameraEffects CameraEffects::Preset(const std::string& name) {
  CameraEffects effects;
  if (name == "ideal") return effects;
  if (name == "webcam") {  // USB UVC: rolling shutter, slow auto exposure
    effects.rolling_shutter_readout = 0.8;
    effects.exposure_drift = 0.05;
    effects.white_balance_drift = 0.02;
    effects.vignetting = 0.2;
    // Indoors a webcam at 30 fps keeps its shutter open about 1/60 s. Its
    // cheap lens: k3 0.15 is 2 px at the corner of a VGA frame (f = 1.1 w)
    // before k1, k2 absorb what they can, and it is decentred by p ~ 2e-3,
    // 0.6-1.6 px at the corners (TUM fr1's published calibration of its
    // webcam-class camera has p1 -5.4e-3, p2 2.6e-3). Small pixels at high
    // gain: 8 e-/level is 4 levels of shot noise at mid-grey.
    effects.exposure_time = 0.5;
    effects.k3 = 0.15;
    effects.p1 = 2e-3;
    effects.p2 = -1.5e-3;
    effects.shot_noise_gain = 8.0;
    return effects;
  }
  if (name == "phone") {  // the phone: readout 0.6, +-12 % exposure, 30 % vignetting
    effects.rolling_shutter_readout = 0.6;
    effects.exposure_drift = 0.12;
    effects.white_balance_drift = 0.03;
    effects.vignetting = 0.3;
    // About 1/120 s in room light; a better-centred lens with a smaller
    // higher-order residual (k3 -0.05: 0.7 px at the corner, p 5e-4: up to 0.5 px);
    // 16 e-/level (2.8 levels at mid-grey) after the phone's own denoising.
    effects.exposure_time = 0.25;
    effects.k3 = -0.05;
    effects.p1 = 5e-4;
    effects.p2 = 5e-4;
    effects.shot_noise_gain = 16.0;
    return effects;
  }
  throw std::invalid_argument("camera effects preset must be ideal, webcam or phone, not '" + name +
                              "'");
}

int CameraEffects::PresetJpegQuality(const std::string& name) {
  // A UVC webcam streams MJPEG to fit 30 fps through USB 2 (quality ~75-85);
  // a phone stores stills at ~90-95 and video with coarser blocks still.
  if (name == "webcam") return 80;
  if (name == "phone") return 90;
  Preset(name);  // throws for an unknown name
  return 0;
}

nlohmann::json ToJson(const CameraEffects& e) {
  return {{"rolling_shutter_readout", e.rolling_shutter_readout},
          {"exposure_drift", e.exposure_drift},
          {"white_balance_drift", e.white_balance_drift},
          {"vignetting", e.vignetting},
          {"exposure_time", e.exposure_time},
          {"motion_blur_samples", e.exposure_time > 0.0 ? CameraEffects::kMotionBlurSamples : 1},
          {"k3", e.k3},
          {"p1", e.p1},
          {"p2", e.p2},
          {"shot_noise_gain", e.shot_noise_gain},
          {"bayer", e.bayer}};
}

cv::Mat BayerMosaic(const cv::Mat& radiance) {
  CV_Assert(radiance.type() == CV_32FC3);
  cv::Mat mosaic(radiance.size(), CV_32FC1);
  cv::parallel_for_(cv::Range(0, radiance.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const cv::Vec3f* in = radiance.ptr<cv::Vec3f>(y);
      float* out = mosaic.ptr<float>(y);
      for (int x = 0; x < radiance.cols; ++x) {
        // Even rows B G B G ..., odd rows G R G R ...; channels are B, G, R.
        const int channel = (y % 2 == 0) ? (x % 2 == 0 ? 0 : 1) : (x % 2 == 0 ? 1 : 2);
        out[x] = in[x][channel];
      }
    }
  });
  return mosaic;
}

cv::Mat Demosaic(const cv::Mat& mosaic) {
  CV_Assert(mosaic.type() == CV_8UC1);
  cv::Mat bgr;
  // OpenCV names a pattern by the second row's second and third pixels: here
  // R and G (CameraEffects.BayerMosaicRoundTripsAFlatColour holds it).
  cv::cvtColor(mosaic, bgr, cv::COLOR_BayerRG2BGR_EA);
  return bgr;
}

Eigen::Vector2d RenderedPixelToUndistorted(const CameraModel& camera, const CameraEffects& effects,
                                           const Eigen::Vector2d& pixel) {
  Eigen::Vector2d x_u = camera.PixelToUndistorted(pixel);
  if (!effects.lens_extras()) return x_u;
  const double x = (pixel.x() - camera.cx) / camera.f, y = (pixel.y() - camera.cy) / camera.f;
  const double r2 = x * x + y * y;
  const double radial = effects.k3 * r2 * r2 * r2;
  x_u.x() += x * radial + 2.0 * effects.p1 * x * y + effects.p2 * (r2 + 2.0 * x * x);
  x_u.y() += y * radial + effects.p1 * (r2 + 2.0 * y * y) + 2.0 * effects.p2 * x * y;
  return x_u;
}

std::optional<Eigen::Vector2d> RenderedUndistortedToPixel(const CameraModel& camera,
                                                          const CameraEffects& effects,
                                                          const Eigen::Vector2d& x_u) {
  std::optional<Eigen::Vector2d> start = camera.UndistortedToPixel(x_u);
  if (!start || !effects.lens_extras()) return start;
  Eigen::Vector2d pixel = *start;
  constexpr double kStep = 1e-3;  // pixels, for the Jacobian's central differences
  for (int iteration = 0; iteration < 20; ++iteration) {
    const Eigen::Vector2d residual =
        camera.f * (RenderedPixelToUndistorted(camera, effects, pixel) - x_u);
    if (residual.norm() < 1e-9) return pixel;
    Eigen::Matrix2d jacobian;
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector2d step = Eigen::Vector2d::Zero();
      step[axis] = kStep;
      jacobian.col(axis) = camera.f *
                           (RenderedPixelToUndistorted(camera, effects, pixel + step) -
                            RenderedPixelToUndistorted(camera, effects, pixel - step)) /
                           (2.0 * kStep);
    }
    if (std::abs(jacobian.determinant()) < 1e-6) return std::nullopt;
    pixel -= jacobian.inverse() * residual;
  }
  return std::nullopt;
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

void AddShotNoise(double gain, int frame_index, uint64_t seed, cv::Mat* image) {
  CV_Assert(image->depth() == CV_32F && image->isContinuous());
  cv::RNG rng(seed * 0x94D049BB133111EBULL + static_cast<uint64_t>(frame_index) * 104729 + 11);
  float* value = image->ptr<float>();
  const size_t count = image->total() * image->channels();
  for (size_t i = 0; i < count; ++i) {
    const double electrons = std::max(0.0, static_cast<double>(value[i])) * gain;
    double drawn;
    if (electrons < 64.0) {
      // Knuth: count uniforms until their product falls below e^-lambda.
      const double limit = std::exp(-electrons);
      double product = rng.uniform(0.0, 1.0);
      int k = 0;
      while (product > limit) {
        ++k;
        product *= rng.uniform(0.0, 1.0);
      }
      drawn = k;
    } else {
      drawn = electrons + std::sqrt(electrons) * rng.gaussian(1.0);
    }
    value[i] = static_cast<float>(drawn / gain);
  }
}

}  // namespace dfsm
