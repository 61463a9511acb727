#include "core/pipeline/depth_check.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/dense/inverse_depth_lattice.h"
#include "core/sparse/fixed_text.h"

namespace dfsm {
namespace {

std::string Percent(double share) { return FixedText(100.0 * share, 0) + " %"; }

// The shares of the measured pixels of `dense` within one lattice plane of the
// swept range's nearest and farthest ends.
void SharesAtRangeEnds(const DenseDepth& dense, double* nearest, double* farthest) {
  *nearest = *farthest = 0.0;
  const InverseDepthLattice lattice{dense.min_inverse_depth, dense.max_inverse_depth, dense.planes};
  if (lattice.planes < 2 || !(lattice.max_inverse_depth > lattice.min_inverse_depth)) return;
  const double near_end = lattice.max_inverse_depth - lattice.step(),
               far_end = lattice.min_inverse_depth + lattice.step();
  long measured = 0, near = 0, far = 0;
  for (int y = 0; y < dense.depth.rows; ++y) {
    const float* depth = dense.depth.ptr<float>(y);
    for (int x = 0; x < dense.depth.cols; ++x) {
      if (!(depth[x] > 0.0f)) continue;
      ++measured;
      const double w = 1.0 / depth[x];
      near += w >= near_end;
      far += w <= far_end;
    }
  }
  if (measured == 0) return;
  *nearest = static_cast<double>(near) / measured;
  *farthest = static_cast<double>(far) / measured;
}

// The verdict on the map as a whole (DepthCheckOptions::unreliable_relief).
void JudgeAsAWhole(const DepthCheckOptions& options, DepthCheck* check) {
  std::vector<std::string>& reasons = check->unreliable_reasons;
  // First: too little motion is the cause the user can act on, and the
  // other measures follow from it.
  if (check->parallax_px < options.min_parallax_px)
    reasons.push_back("the tracks moved " + FixedText(check->parallax_px) +
                      " px beyond the camera's rotation, less than the " +
                      FixedText(options.min_parallax_px) + " px depth needs");
  for (const std::string& why : check->implausible_camera)
    reasons.push_back("the camera the burst estimated for it is implausible: " + why);
  if (check->relief_sigma >= options.unreliable_relief)
    reasons.push_back("the camera's uncertainty leaves the relief uncertain by " +
                      Percent(check->relief_sigma));
  if (check->lens_relief_shift >= options.unreliable_relief)
    reasons.push_back("the relief moves by " + Percent(check->lens_relief_shift) +
                      " with the lens model");
  if (check->camera_relief_disagreement >= options.unreliable_relief)
    reasons.push_back("the relief moves by " + Percent(check->camera_relief_disagreement) +
                      " with the camera");
  if (check->median_disagreement >= options.unreliable_relief)
    reasons.push_back("the map disagrees with the tracks by a median of " +
                      Percent(check->median_disagreement));
  const double at_end = std::max(check->at_nearest_plane, check->at_farthest_plane);
  if (at_end >= options.unreliable_range_end_fraction)
    reasons.push_back(Percent(at_end) + " of the measured pixels sit at an end of the swept range");
  check->quality = !reasons.empty()     ? DepthQuality::kUnreliable
                   : check->Confirmed() ? DepthQuality::kConfirmed
                                        : DepthQuality::kUncertain;
}

}  // namespace

DepthCheck CheckDepthAgainstTracks(const SparseReconstruction& sparse, const DenseDepth& dense,
                                   const DepthCheckOptions& options) {
  options.Check();
  DepthCheck check;
  const FeatureTracks& tracks = sparse.tracks;
  check.parallax_px = sparse.parallax.median_px;
  if (check.parallax_px < options.min_parallax_px)
    check.warnings.push_back(
        "move the camera a little: the tracks moved " + FixedText(check.parallax_px) +
        " px beyond the camera's rotation (median), and depth needs " +
        FixedText(options.min_parallax_px) +
        " px; hold it by hand, not on a table, and let it drift a few millimetres");
  std::vector<double> disagreement;
  for (int j = 0; j < tracks.num_tracks(); ++j) {
    if (!sparse.inliers[j]) continue;
    ++check.tracks;
    const Eigen::Vector2d pixel = tracks.pixels[tracks.reference].col(j);
    const int u = static_cast<int>(std::lround(pixel.x())),
              v = static_cast<int>(std::lround(pixel.y()));
    if (u < 0 || v < 0 || u >= dense.depth.cols || v >= dense.depth.rows) continue;
    const float depth = dense.depth.at<float>(v, u);
    if (!(depth > 0.0f)) continue;
    ++check.compared;
    disagreement.push_back(std::abs(1.0 / depth / sparse.state.inverse_depths[j] - 1.0));
  }
  if (!disagreement.empty()) {
    check.within_10_percent =
        static_cast<double>(std::count_if(disagreement.begin(), disagreement.end(),
                                          [](double d) { return d <= 0.10; })) /
        disagreement.size();
    std::nth_element(disagreement.begin(), disagreement.begin() + disagreement.size() / 2,
                     disagreement.end());
    check.median_disagreement = disagreement[disagreement.size() / 2];
  }
  const double covered = check.tracks > 0 ? double(check.compared) / check.tracks : 0.0;
  if (check.median_disagreement > options.max_median_disagreement)
    check.warnings.push_back(
        "depth not confirmed: the dense map disagrees with the sparse points "
        "by a median of " +
        Percent(check.median_disagreement) + " (" + Percent(check.within_10_percent) + " of " +
        std::to_string(check.compared) + " tracks within 10 %)");
  if (covered < options.min_tracks_covered)
    check.warnings.push_back("depth sparse: the dense map has depth at " + Percent(covered) +
                             " of the tracked points");
  check.outlier_fraction = dense.outlier_fraction;
  if (dense.outlier_fraction > options.max_outlier_fraction)
    check.warnings.push_back("depth outliers: " + Percent(dense.outlier_fraction) +
                             " of the pixels match no depth of a still scene (something moved, "
                             "or reflections); they have no depth");
  check.relief_sigma = sparse.uncertainty.relief_sigma;
  if (check.relief_sigma > options.max_relief_sigma)
    check.warnings.push_back(
        "depth relief uncertain: the camera's uncertainty (poses, focal length, distortion, "
        "readout) leaves relative depths uncertain by " +
        Percent(check.relief_sigma) + " (1 sigma); a higher resolution measures the poses better");
  check.lens_relief_shift = sparse.lens_relief_shift;
  if (check.lens_relief_shift > options.max_lens_relief_shift)
    check.warnings.push_back(
        "depth relief depends on the lens model: with k1 alone the tracks' relative depths "
        "move by " +
        Percent(check.lens_relief_shift) +
        " (median); the lens distorts more than k1 and k2 describe (a wide angle?), and the "
        "depth may be wrong as a whole");
  check.camera_relief_disagreement = sparse.camera_relief_disagreement;
  if (check.camera_relief_disagreement > options.max_camera_relief_disagreement)
    check.warnings.push_back(
        "depth relief depends on the camera: with the camera the burst calibrates alone, the "
        "tracks' relative depths move by " +
        Percent(check.camera_relief_disagreement) +
        " (median); a camera slightly off bends this depth, which may be wrong as a whole");
  check.range_extended = dense.range_extended;
  check.implausible_camera = sparse.implausible_camera;
  check.known_calibration_fits = !sparse.known_fit || sparse.known_fit->fits;
  check.estimated_camera_used = !sparse.DroppedLensTerms();
  SharesAtRangeEnds(dense, &check.at_nearest_plane, &check.at_farthest_plane);
  if (check.at_nearest_plane > options.max_range_end_fraction)
    check.warnings.push_back(
        "depth clamped: " + Percent(check.at_nearest_plane) +
        " of the measured pixels sit at the nearest swept depth; a surface nearer than every "
        "tracked point (no track on it) is shown there, farther than it is");
  if (check.at_farthest_plane > options.max_range_end_fraction)
    check.warnings.push_back(
        "depth clamped: " + Percent(check.at_farthest_plane) +
        " of the measured pixels sit at the farthest swept depth; a surface farther than every "
        "tracked point (no track on it) is shown there, nearer than it is");
  if (dense.valid_fraction < options.min_valid_fraction)
    check.warnings.push_back("depth sparse: " + Percent(dense.valid_fraction) +
                             " of the pixels have a depth");
  JudgeAsAWhole(options, &check);
  return check;
}

const char* DepthQualityName(DepthQuality quality) {
  switch (quality) {
    case DepthQuality::kConfirmed:
      return "confirmed";
    case DepthQuality::kUncertain:
      return "uncertain";
    case DepthQuality::kUnreliable:
      return "unreliable";
  }
  return "unknown";
}

void DepthCheckOptions::Check() const {
  if (!(min_parallax_px >= 0.0))
    throw std::invalid_argument("min_parallax_px must be >= 0, got " +
                                std::to_string(min_parallax_px));
  if (!(max_camera_relief_disagreement > 0.0))
    throw std::invalid_argument("max_camera_relief_disagreement must be > 0, got " +
                                std::to_string(max_camera_relief_disagreement));
  if (!(unreliable_relief > 0.0))
    throw std::invalid_argument("unreliable_relief must be > 0, got " +
                                std::to_string(unreliable_relief));
  if (!(unreliable_range_end_fraction > 0.0 && unreliable_range_end_fraction <= 1.0))
    throw std::invalid_argument("unreliable_range_end_fraction must be in (0, 1], got " +
                                std::to_string(unreliable_range_end_fraction));
}

nlohmann::json DepthVerdictJson(const DepthCheck& check) {
  return {{"quality", DepthQualityName(check.quality)}, {"reasons", check.unreliable_reasons}};
}

nlohmann::json ToJson(const DepthCheck& check) {
  return {{"tracks", check.tracks},
          {"compared", check.compared},
          {"median_disagreement", check.median_disagreement},
          {"within_10_percent", check.within_10_percent},
          {"outlier_fraction", check.outlier_fraction},
          {"relief_sigma", check.relief_sigma},
          {"lens_relief_shift", check.lens_relief_shift},
          {"camera_relief_disagreement", check.camera_relief_disagreement},
          {"at_nearest_plane", check.at_nearest_plane},
          {"at_farthest_plane", check.at_farthest_plane},
          {"range_extended", check.range_extended},
          {"known_calibration_fits", check.known_calibration_fits},
          {"estimated_camera_used", check.estimated_camera_used},
          {"confirmed", check.Confirmed()}};
}

}  // namespace dfsm
