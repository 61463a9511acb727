// The verdict on one burst's calibration: whether the user can believe the
// focal length and distortion it reports. Small motion shows f only through
// second-order effects and trades it against k1/k2, so a calibration that fits
// the tracks well can still be far off; the verdict reads how well the burst
// determines the camera (the uncertainty of the adjustment) and what is known
// to break the method, and names every reason it found.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/sparse/calibration_uncertainty.h"

namespace dfsm {

enum class CalibrationQuality { kReliable, kUncertain, kDegenerate };
const char* CalibrationQualityName(CalibrationQuality quality);  // "reliable" | ...

// The thresholds (docs/sparse.md, "Calibration uncertainty and the verdict"), measured
// over the calibration sweep (docs/experiments/104-calibration-sweep.md).
struct CalibrationQualityOptions {
  // reliable needs all of these
  double max_reliable_sigma_f_percent = 0.5;  // so that 2 sigma stays within 1 %
  double max_reliable_distortion_sigma_px = 0.25;
  int min_reliable_tracks = 60;
  double max_reliable_rms_px = 0.5;
  double min_reliable_parallax_px = 0.5;    // median largest track motion
  double max_reliable_correlation = 0.999;  // |corr(f, k1)|: f and k1 indistinguishable
  // degenerate beyond these
  double max_sigma_f_percent = 10.0;  // f is then the prior's, not the burst's
  double min_f_ratio = 0.2;           // f / max(width, height): a plausible lens
  double max_f_ratio = 10.0;

  // Throws std::invalid_argument naming a threshold out of range.
  void Check() const;
};

// What the sparse stage measured besides the uncertainty.
struct CalibrationEvidence {
  int tracks = 0;  // inliers of the final adjustment
  double rms_reprojection_px = 0.0;
  double median_track_motion_px = 0.0;  // parallax
  bool intrinsics_estimated = true;     // false: a known calibration was held fixed
};

struct CalibrationVerdict {
  CalibrationQuality quality = CalibrationQuality::kDegenerate;
  std::vector<std::string> reasons;  // empty only for reliable
};

// True when the D->U map is monotone in the radius over the whole image (the
// model does not fold the image over itself); otherwise *fold_radius_px is the
// first radius, from the principal point, where it folds.
bool RadialModelIsMonotone(const CameraModel& camera, double* fold_radius_px = nullptr);

// Why `camera` is no camera's at all, whatever the evidence for it: the lens
// folds within the image, or f is outside [min_f_ratio, max_f_ratio] of the
// image size. One sentence per reason; empty where the camera is plausible.
std::vector<std::string> ImplausibleCamera(const CameraModel& camera,
                                           const CalibrationQualityOptions& options = {});

CalibrationVerdict JudgeCalibration(const CameraModel& camera,
                                    const CalibrationUncertainty& uncertainty,
                                    const CalibrationEvidence& evidence,
                                    const CalibrationQualityOptions& options = {});

nlohmann::json ToJson(const CalibrationVerdict& verdict);

}  // namespace dfsm
