// What a real camera does to a burst beyond the pinhole and its lens, for the
// generator to render (issue: real footage): rolling shutter, auto exposure
// and white-balance drift between frames, vignetting. Each is off at 0, so a
// burst without them is rendered exactly as before; the ground truth keeps its
// meaning (a rolling-shutter frame's pose is that of its middle row).
#pragma once

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/camera/pose.h"

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

  // Throws std::invalid_argument naming an out-of-range effect.
  void Check() const;
  bool any() const;
  // Named presets: "ideal" (all 0), "webcam", "phone". Throws
  // std::invalid_argument for another name.
  static CameraEffects Preset(const std::string& name);
};

nlohmann::json ToJson(const CameraEffects& effects);

// The pose at fractional frame time t of a path with one pose per frame:
// linear in the camera centre and in the rotation's angle-axis between the
// frames around t, extrapolated from the first or last two beyond the ends.
Pose PoseAtTime(const std::vector<Pose>& poses, double t);

// Scales `radiance` (CV_32FC3, grey levels) by frame `frame_index`'s
// exposure, white balance and the vignetting. Deterministic for (seed, frame).
void ApplyPhotometricEffects(const CameraEffects& effects, int frame_index, uint64_t seed,
                             cv::Mat* radiance);

}  // namespace dfsm
