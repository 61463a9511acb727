#include "core/sparse/calibration_quality.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/sparse/fixed_text.h"

namespace dfsm {
namespace {

void Require(bool condition, const char* what) {
  if (!condition) throw std::invalid_argument(std::string("calibration quality: ") + what);
}

}  // namespace

const char* CalibrationQualityName(CalibrationQuality quality) {
  switch (quality) {
    case CalibrationQuality::kReliable:
      return "reliable";
    case CalibrationQuality::kUncertain:
      return "uncertain";
    case CalibrationQuality::kDegenerate:
      return "degenerate";
  }
  return "degenerate";
}

void CalibrationQualityOptions::Check() const {
  Require(max_reliable_sigma_f_percent > 0.0 && max_reliable_sigma_f_percent <= max_sigma_f_percent,
          "max_reliable_sigma_f_percent must be in (0, max_sigma_f_percent]");
  Require(max_reliable_distortion_sigma_px > 0.0, "max_reliable_distortion_sigma_px must be > 0");
  Require(min_reliable_tracks >= 0, "min_reliable_tracks must be >= 0");
  Require(max_reliable_rms_px > 0.0, "max_reliable_rms_px must be > 0");
  Require(min_reliable_parallax_px >= 0.0, "min_reliable_parallax_px must be >= 0");
  Require(max_reliable_correlation > 0.0 && max_reliable_correlation <= 1.0,
          "max_reliable_correlation must be in (0, 1]");
  Require(min_f_ratio > 0.0 && min_f_ratio < max_f_ratio, "need 0 < min_f_ratio < max_f_ratio");
}

bool RadialModelIsMonotone(const CameraModel& camera, double* fold_radius_px) {
  const double corner_px = camera.CornerRadiusPx();
  // d(r_u)/d(r_d) = 1 + 3 k1 r^2 + 5 k2 r^4 must stay positive out to the corner.
  constexpr int kSteps = 256;
  for (int step = 1; step <= kSteps; ++step) {
    const double r = corner_px * step / kSteps / camera.f;
    const double r2 = r * r;
    if (!(1.0 + 3.0 * camera.k1 * r2 + 5.0 * camera.k2 * r2 * r2 > 0.0)) {
      if (fold_radius_px) *fold_radius_px = corner_px * step / kSteps;
      return false;
    }
  }
  return true;
}

std::vector<std::string> ImplausibleCamera(const CameraModel& camera,
                                           const CalibrationQualityOptions& options) {
  std::vector<std::string> reasons;
  double fold_px = 0.0;
  if (!RadialModelIsMonotone(camera, &fold_px))
    reasons.push_back("lens model folds: the distortion (k1 " + FixedText(camera.k1, 4) + ", k2 " +
                      FixedText(camera.k2, 4) + ") maps the image over itself " +
                      FixedText(fold_px, 0) + " px from the centre");
  const double f_ratio = camera.f / std::max(camera.width, camera.height);
  if (!(f_ratio >= options.min_f_ratio && f_ratio <= options.max_f_ratio))
    reasons.push_back("implausible focal length: f " + FixedText(camera.f, 1) + " px is " +
                      FixedText(f_ratio) + " x the image size (expected " +
                      FixedText(options.min_f_ratio) + "-" + FixedText(options.max_f_ratio) + ")");
  return reasons;
}

CalibrationVerdict JudgeCalibration(const CameraModel& camera,
                                    const CalibrationUncertainty& uncertainty,
                                    const CalibrationEvidence& evidence,
                                    const CalibrationQualityOptions& options) {
  CalibrationVerdict verdict;
  std::vector<std::string> uncertain;
  if (!evidence.intrinsics_estimated) {
    verdict.quality = CalibrationQuality::kReliable;
    verdict.reasons.push_back("known calibration held fixed: not estimated from this burst");
    return verdict;
  }
  std::vector<std::string> degenerate = ImplausibleCamera(camera, options);
  if (!uncertainty.available) {
    degenerate.push_back("no uncertainty: " + uncertainty.unavailable_reason);
  } else {
    const double sigma_f = uncertainty.sigma_f_percent(camera.f);
    if (sigma_f > options.max_sigma_f_percent)
      degenerate.push_back(
          "focal length not observed: sigma_f " + FixedText(sigma_f) + " % > " +
          FixedText(options.max_sigma_f_percent, 1) + " % " +
          (uncertainty.wide_angle_factor > 1.0
               ? "(a wide lens: the sigma is inflated " +
                     FixedText(uncertainty.wide_angle_factor, 1) +
                     "x for the lens model's error at this field of view; a known calibration of "
                     "the camera avoids it)"
               : std::string("(the prior, not the burst, sets f)")));
    else if (sigma_f > options.max_reliable_sigma_f_percent)
      uncertain.push_back("weak focal length: sigma_f " + FixedText(sigma_f) + " % > " +
                          FixedText(options.max_reliable_sigma_f_percent) + " %");
    if (uncertainty.distortion_sigma_px > options.max_reliable_distortion_sigma_px)
      uncertain.push_back("weak distortion: sigma " + FixedText(uncertainty.distortion_sigma_px) +
                          " px > " + FixedText(options.max_reliable_distortion_sigma_px) + " px");
    const double correlation = std::abs(uncertainty.correlation(0, 1));
    if (correlation > options.max_reliable_correlation)
      uncertain.push_back("f and k1 strongly correlated: |corr| " + FixedText(correlation, 4) +
                          " > " + FixedText(options.max_reliable_correlation, 4));
  }
  if (evidence.tracks < options.min_reliable_tracks)
    uncertain.push_back("few tracks: " + std::to_string(evidence.tracks) + " < " +
                        std::to_string(options.min_reliable_tracks));
  if (evidence.rms_reprojection_px > options.max_reliable_rms_px)
    uncertain.push_back("high residual: RMS " + FixedText(evidence.rms_reprojection_px) + " px > " +
                        FixedText(options.max_reliable_rms_px) + " px");
  if (evidence.median_track_motion_px < options.min_reliable_parallax_px)
    uncertain.push_back("little parallax: median track motion " +
                        FixedText(evidence.median_track_motion_px) + " px < " +
                        FixedText(options.min_reliable_parallax_px) + " px");
  verdict.quality = !degenerate.empty()  ? CalibrationQuality::kDegenerate
                    : !uncertain.empty() ? CalibrationQuality::kUncertain
                                         : CalibrationQuality::kReliable;
  verdict.reasons = degenerate;
  verdict.reasons.insert(verdict.reasons.end(), uncertain.begin(), uncertain.end());
  return verdict;
}

nlohmann::json ToJson(const CalibrationVerdict& verdict) {
  return {{"quality", CalibrationQualityName(verdict.quality)}, {"reasons", verdict.reasons}};
}

}  // namespace dfsm
