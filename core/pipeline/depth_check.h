// Whether the dense depth can be vouched for without ground truth: the
// bundle adjustment's inlier tracks are points whose inverse depth the burst
// measured directly, in the same scale as the dense map, so the map must agree
// with them where it has depth. A map that disagrees, or covers little of the
// image, is reported with a warning instead of a silent "ok". What it cannot
// see is a geometry that is wrong as a whole (calibration, poses): the dense
// map then agrees with equally wrong sparse points; the calibration verdict is
// the check for that.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/dense/dense_depth.h"
#include "core/pipeline/burst_length.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {

struct DepthCheckOptions {
  // Warn when the median |w_dense / w_track - 1| over the tracks exceeds this
  // (docs/experiments/210-tum-fr1-xyz.md: 0.7-1.5 % on generated bursts, 0.1-2.3 % on TUM windows:
  // the dense stage follows the sparse geometry, right or wrong) ...
  double max_median_disagreement = 0.10;
  // ... or when the map has depth at fewer than this share of the tracks or
  // of the pixels.
  double min_tracks_covered = 0.5;
  double min_valid_fraction = 0.5;
  // Warn when more than this share of the pixels are photo-consistency
  // outliers (DenseDepth::outlier_fraction;
  // docs/experiments/220-photo-consistency-outliers.md: at most 0.6 % on
  // generated bursts of a still scene, 0.1-0.5 % on TUM fr1/xyz, 3.5-6 % with a
  // moving object).
  double max_outlier_fraction = 0.02;
  // Warn when the camera's uncertainty leaves the relief more uncertain than
  // this (CalibrationUncertainty::relief_sigma, 1 sigma: the relative depth
  // error the tracks share, which agreeing with them cannot reveal).
  // docs/experiments/123-relief-uncertainty.md: 2.9-4.9 % on generated 1080p
  // and phone VGA bursts that score 2.0-3.2 % AbsRel, 6-24 % on those that
  // score 3.4-12 % (VGA with 2 deg tremor, webcams, 320x240), 0.5-4 % on TUM.
  double max_relief_sigma = 0.05;
  // Warn when the relief moves by more than this with the lens model
  // (SparseReconstruction::lens_relief_shift;
  // docs/experiments/124-lens-relief-shift.md: 0.02-2 % on generated bursts that
  // score 0.8-6.7 % AbsRel, 5 % on two webcam bursts at 5.4 and 8.8 %, 34 and
  // 46 % on two wide-angle phone bursts at 12 and 22 %; 0.05-4 % on TUM).
  double max_lens_relief_shift = 0.10;
  // Warn when the relief moves by more than this with the camera
  // (SparseReconstruction::camera_relief_disagreement: the burst calibrated
  // alone beside a known camera; docs/experiments/016-camera-relief-disagreement.md:
  // at most 4.9 % on TUM fr1/xyz and on the one fr1/rpy window better than
  // 11 %, at most 2.6 % on the generator's confirmed maps; 10.6 % on an
  // fr1/rpy window worse than a constant depth that was confirmed).
  double max_camera_relief_disagreement = 0.075;
  // Warn when more than this share of the measured pixels sit within one
  // plane of either end of the swept range. The range is the tracks' widened
  // by DenseOptions::inverse_depth_margin, so a surface nearer (or farther)
  // than every inlier track is swept only to the range's end, and its pixels
  // take the end plane: a whole plane 60 % too far while the tracks agreed
  // (docs/experiments/228-depth-sweep.md: 18 % of the pixels at the near end
  // there, 54 % at the far end of a burst 134 % off; at most 0.1 % near and
  // 0.33 % far on 75 other generated bursts, up to 1.6 % near on TUM fr1/xyz,
  // where the desk's nearest edge has no tracks). The dense stage extends the
  // range toward the camera once (DenseOptions::range_extension_share); this
  // warns of what is left at either end after it.
  double max_range_end_fraction = 0.03;
  // The inlier tracks' parallax (Parallax::median_px: their motion with the
  // frames' rotation taken out) below which the burst moved too little to
  // separate depths: the map is unreliable, and the warning says to move the
  // camera a little.
  double min_parallax_px = kTooStillParallaxPx;

  // The map is likely wrong as a whole (DepthQuality::kUnreliable) where the
  // relief's sigma, its shift with the lens model, its disagreement with the
  // burst's own camera or the map's median disagreement with the tracks
  // reaches unreliable_relief, where
  // unreliable_range_end_fraction of its pixels sit at one end of the swept
  // range, where the parallax is below min_parallax_px, and where the camera
  // the burst estimated for the depth is implausible (SparseReconstruction::
  // implausible_camera; docs/experiments/037-depth-from-an-implausible-camera.md).
  // docs/experiments/142-depth-verdict.md: on TUM fr1/rpy every window worse
  // than a constant depth but one (20.0 against 19.0 %) reaches one of these;
  // on the generator's phone depth sweep the two maps off by more than 15 %
  // do and no other.
  double unreliable_relief = 0.25;
  double unreliable_range_end_fraction = 0.25;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

// How far a depth map can be vouched for as a whole.
enum class DepthQuality {
  kConfirmed,   // agrees with the tracks; nothing upstream doubts the geometry
  kUncertain,   // a warning applies, but none that makes the whole map suspect
  kUnreliable,  // likely wrong as a whole: flattened, exaggerated or inverted
};

const char* DepthQualityName(DepthQuality quality);

struct DepthCheck {
  int tracks = 0;                    // inlier tracks
  int compared = 0;                  // of them, with a dense depth at their pixel
  double median_disagreement = 0.0;  // median |w_dense / w_track - 1|
  double within_10_percent = 0.0;    // share of the compared tracks
  double outlier_fraction = 0.0;     // DenseDepth::outlier_fraction
  double relief_sigma = -1.0;        // CalibrationUncertainty::relief_sigma
  double lens_relief_shift = -1.0;   // SparseReconstruction::lens_relief_shift
  // SparseReconstruction::camera_relief_disagreement
  double camera_relief_disagreement = -1.0;
  // SparseReconstruction::parallax.median_px (result.json's parallax).
  double parallax_px = 0.0;
  // SparseReconstruction::implausible_camera.
  std::vector<std::string> implausible_camera;
  // Shares of the measured pixels within one plane of the swept range's
  // nearest and farthest ends.
  double at_nearest_plane = 0.0, at_farthest_plane = 0.0;
  // DenseDepth::range_extended: the swept range was extended toward the
  // camera beyond the tracks'.
  bool range_extended = false;
  // SparseReconstruction::KnownFit::fits, true where no known calibration
  // was checked. A known camera that does not fit the burst placed the tracks
  // too, so agreeing with them confirms nothing (TUM fr1/xyz frames 18-27:
  // 15.7 % AbsRel, the map within 0.5 % of the tracks). The sparse stage
  // already warns; the check only withholds `confirmed`.
  bool known_calibration_fits = true;
  // False where the dense stage could not use the camera the adjustment
  // estimated and the tracks were refitted with fewer lens terms
  // (SparseReconstruction::DroppedLensTerms).
  // The refit's relief is the one the burst's own lens model did not choose,
  // and how far it moved is not measured (lens_relief_shift is -1): on the
  // wide depth sweep, such maps came out 6-12 % off while agreeing with their
  // tracks (docs/experiments/229-radial-inverse-range.md). The sparse stage
  // already warns; the check only withholds `confirmed`.
  bool estimated_camera_used = true;
  std::vector<std::string> warnings;  // empty: nothing to say
  DepthQuality quality = DepthQuality::kUncertain;
  // Why the map is kUnreliable (empty otherwise), each with its measure.
  std::vector<std::string> unreliable_reasons;

  // The map agrees with the tracks and nothing upstream doubts the geometry
  // they were placed in.
  bool Confirmed() const {
    return warnings.empty() && known_calibration_fits && estimated_camera_used;
  }
};

DepthCheck CheckDepthAgainstTracks(const SparseReconstruction& sparse, const DenseDepth& dense,
                                   const DepthCheckOptions& options = {});

nlohmann::json ToJson(const DepthCheck& check);

// result.json's "depth_verdict": {"quality", "reasons"}.
nlohmann::json DepthVerdictJson(const DepthCheck& check);

}  // namespace dfsm
