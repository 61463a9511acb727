#include "core/sparse/parallax.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace dfsm {
namespace {

// The value at `share` (0..1) of `values` (reordered).
double Quantile(std::vector<double>* values, double share) {
  if (values->empty()) return 0.0;
  const size_t at = std::min(values->size() - 1, static_cast<size_t>(share * values->size()));
  std::nth_element(values->begin(), values->begin() + at, values->end());
  return (*values)[at];
}

// Track j's largest motion from the reference over the frames, each
// observation's ray turned back by its frame's rotation, pixels.
double DerotatedMotion(const FeatureTracks& tracks, const SparseState& state, int j) {
  const CameraModel& camera = state.camera;
  const Eigen::Vector2d reference =
      camera.PixelToUndistorted(tracks.pixels[tracks.reference].col(j));
  double largest = 0.0;
  for (int i = 0; i < tracks.num_frames(); ++i) {
    if (i == tracks.reference) continue;
    const Eigen::Vector2d seen = camera.PixelToUndistorted(tracks.pixels[i].col(j));
    // X_i = R_i X_ref + T_i: R_i^T turns the frame's ray to the reference's
    // orientation, leaving the translation's share of the motion.
    const Eigen::Vector3d ray = state.poses[i].R.transpose() * seen.homogeneous();
    if (!(ray.z() > 0.0)) continue;
    largest = std::max(largest, camera.f * (ray.hnormalized() - reference).norm());
  }
  return largest;
}

}  // namespace

Parallax MeasureParallax(const FeatureTracks& tracks, const std::vector<bool>& use,
                         const SparseState& state, double noise_px) {
  Parallax parallax;
  std::vector<double> motion, inverse_depths;
  for (int j = 0; j < tracks.num_tracks(); ++j) {
    if (!use[j]) continue;
    motion.push_back(DerotatedMotion(tracks, state, j));
    inverse_depths.push_back(state.inverse_depths[j]);
  }
  if (motion.empty()) return parallax;
  parallax.median_px = Quantile(&motion, 0.5);
  parallax.p90_px = Quantile(&motion, 0.9);
  double baseline = 0.0;
  for (const Pose& pose : state.poses) baseline = std::max(baseline, pose.Centre().norm());
  // Depth is 1 / inverse depth, in the poses' scale.
  parallax.baseline_over_depth = baseline * std::abs(Quantile(&inverse_depths, 0.5));
  if (parallax.median_px > 0.0) parallax.relative_depth_sigma = noise_px / parallax.median_px;
  return parallax;
}

}  // namespace dfsm
