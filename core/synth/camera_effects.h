// What a real camera does to a burst beyond the pinhole and its lens, for the
// generator to render (issue 13: real footage): rolling shutter, auto exposure
// and white-balance drift between frames, vignetting, motion blur, lens
// distortion beyond the model's two radial terms, signal-dependent (shot)
// noise. Each is off at 0, so a burst without them is rendered exactly as
// before; the ground truth keeps its meaning (a frame's pose is that of its
// middle row at the middle of its exposure; the camera is the model the
// pipeline estimates, the extra lens terms are recorded beside it).
#pragma once

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/camera/camera_model.h"

namespace dfsm {

struct CameraEffects {
  // Rolling shutter: the time from the first row to the last, as a fraction
  // of the frame interval (a phone reads out in about 0.6 of it, a global
  // shutter in 0). Row v is exposed at the frame's time + readout (v / h - 0.5).
  double rolling_shutter_readout = 0.0;
  // Auto exposure and gain: each frame's brightness is scaled by 1 + d, d
  // uniform in [-exposure_drift, exposure_drift] (0.12: +-12 %); the
  // reference frame keeps 1.
  double exposure_drift = 0.0;
  // White balance: each colour channel of a frame scaled by 1 + d, d uniform
  // in [-white_balance_drift, white_balance_drift].
  double white_balance_drift = 0.0;
  // Vignetting: brightness falls as 1 - vignetting (r / r_corner)^2, 0.3 at
  // the corner for 0.3.
  double vignetting = 0.0;
  // Motion blur: the shutter is open for this fraction of the frame interval,
  // centred on the frame's (row's) time; rendered as the mean of
  // kMotionBlurSamples sub-frame renders along the camera path.
  double exposure_time = 0.0;
  // Lens distortion beyond the model (rendering only; the pipeline models k1,
  // k2): added to the D->U map of the captured normalized point (x, y), r^2 =
  // x^2 + y^2: x_u += x k3 r^6 + 2 p1 x y + p2 (r^2 + 2 x^2),
  //            y_u += y k3 r^6 + p1 (r^2 + 2 y^2) + 2 p2 x y.
  double k3 = 0.0, p1 = 0.0, p2 = 0.0;
  // Shot noise: electrons per grey level (the sensor's conversion gain seen
  // through the 8-bit output). A pixel of level L collects L * gain electrons,
  // Poisson distributed, so its variance is L / gain grey levels^2; the
  // Gaussian noise_sigma of SynthOptions is the read noise beside it. 0: off.
  double shot_noise_gain = 0.0;
  // Colour filter array: each photosite sees one colour of the 2x2 pattern
  // B G / G R (BayerMosaic); the shot and read noise fall on the photosites,
  // and the frame is demosaiced (Demosaic) before the JPEG round trip. Its
  // noise is then correlated over neighbouring pixels, so that less of it
  // averages out on a sweep's coarse levels, and its edges carry the
  // demosaicing's colour fringes, as in every phone and webcam frame. Colour
  // frames only: a grey burst is a monochrome sensor.
  bool bayer = false;

  static constexpr int kMotionBlurSamples = 8;

  // Throws std::invalid_argument naming an out-of-range effect.
  void Check() const;
  bool any() const;
  // The per-frame brightness changes (exposure, white balance, vignetting).
  bool photometric() const;
  bool lens_extras() const { return k3 != 0.0 || p1 != 0.0 || p2 != 0.0; }
  // Named presets: "ideal" (all 0), "webcam", "phone". Throws
  // std::invalid_argument for another name.
  static CameraEffects Preset(const std::string& name);
  // The JPEG quality that goes with a preset (0: none for "ideal").
  static int PresetJpegQuality(const std::string& name);
};

nlohmann::json ToJson(const CameraEffects& effects);

// The rendering's D->U map of a captured pixel: the camera's model plus the
// extra lens terms of `effects`; exactly camera.PixelToUndistorted without them.
Eigen::Vector2d RenderedPixelToUndistorted(const CameraModel& camera, const CameraEffects& effects,
                                           const Eigen::Vector2d& pixel);
// Its inverse by Gauss-Newton from the camera model's inverse; empty where it
// does not converge to 1e-9 px.
std::optional<Eigen::Vector2d> RenderedUndistortedToPixel(const CameraModel& camera,
                                                          const CameraEffects& effects,
                                                          const Eigen::Vector2d& x_u);

// Scales `radiance` (CV_32FC3, grey levels) by frame `frame_index`'s
// exposure, white balance and the vignetting. Deterministic for (seed, frame).
void ApplyPhotometricEffects(const CameraEffects& effects, int frame_index, uint64_t seed,
                             cv::Mat* radiance);

// The photosites of a colour filter array (CameraEffects::bayer) over
// `radiance` (CV_32FC3, BGR): CV_32FC1, the blue value where row and column
// are even, red where both are odd, green elsewhere.
cv::Mat BayerMosaic(const cv::Mat& radiance);

// The camera's demosaicing of an 8-bit mosaic of BayerMosaic's pattern:
// CV_8UC3 (BGR), OpenCV's edge-aware interpolation.
cv::Mat Demosaic(const cv::Mat& mosaic);

// Replaces each value L of `image` (CV_32FC1 or CV_32FC3, grey levels) by a
// Poisson draw of L * gain electrons divided by gain (a Gaussian of the same
// mean and variance above 64 electrons). Deterministic for (seed, frame).
void AddShotNoise(double gain, int frame_index, uint64_t seed, cv::Mat* image);

}  // namespace dfsm
