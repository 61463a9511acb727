#include "bench/pinned_depth.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "bench/tum_sequence.h"
#include "core/pipeline/frame_selection.h"
#include "core/sparse/bundle_adjustment.h"

namespace dfsm {

void PinnedDepthOptions::Check() const {
  if (flat_radius < 0) throw std::invalid_argument("pinned depth: flat_radius must be >= 0");
  if (!(flat_tolerance > 0.0))
    throw std::invalid_argument("pinned depth: flat_tolerance must be > 0");
  if (min_tracks < 1) throw std::invalid_argument("pinned depth: min_tracks must be >= 1");
}

namespace {

// The truth's depth at `pixel` where it is flat around it (options), else 0.
double FlatTruthDepth(const cv::Mat& truth, const Eigen::Vector2d& pixel,
                      const PinnedDepthOptions& options) {
  const int x = static_cast<int>(std::lround(pixel.x())),
            y = static_cast<int>(std::lround(pixel.y()));
  const int r = options.flat_radius;
  if (x < r || y < r || x >= truth.cols - r || y >= truth.rows - r) return 0.0;
  const double z = truth.at<float>(y, x);
  if (!(z > 0.0)) return 0.0;
  for (int v = y - r; v <= y + r; ++v)
    for (int u = x - r; u <= x + r; ++u) {
      const double around = truth.at<float>(v, u);
      if (!(around > 0.0) || std::abs(around / z - 1.0) > options.flat_tolerance) return 0.0;
    }
  return z;
}

// The median over the used tracks of each one's RMS error at `state`.
double MedianTrackError(const FeatureTracks& tracks, const std::vector<bool>& use,
                        const SparseState& state) {
  const std::vector<double> errors = TrackReprojectionErrors(tracks, state);
  std::vector<double> used;
  for (int j = 0; j < tracks.num_tracks(); ++j)
    if (use[j]) used.push_back(errors[j]);
  return WindowMedian(used);
}

DepthEvaluation DenseOver(const Burst& kept, const cv::Mat& truth, const cv::Mat& mask,
                          const FeatureTracks& tracks, const std::vector<bool>& use,
                          const SparseState& state, DenseOptions dense) {
  dense.readout = state.readout;
  dense.frame_times = state.frame_times;
  dense.angular_velocities = state.angular_velocities;
  std::vector<double> inliers;
  for (int j = 0; j < tracks.num_tracks(); ++j)
    if (use[j] && state.inverse_depths[j] > 0.0) inliers.push_back(state.inverse_depths[j]);
  const DenseDepth depth = ComputeDenseDepth(kept, state.camera, state.poses, inliers, dense);
  return EvaluateDepth(depth.depth, truth, mask);
}

// PinnedDepth::parallax_range_px of `state`, whose inverse depths are
// `scale` x the truth's.
double ParallaxRangePx(const cv::Mat& truth, const cv::Mat& mask, const SparseState& state,
                       double scale) {
  std::vector<double> inverse;
  for (int y = 0; y < truth.rows; ++y)
    for (int x = 0; x < truth.cols; ++x) {
      const float z = truth.at<float>(y, x);
      if (z > 0.0f && (mask.empty() || mask.at<uchar>(y, x))) inverse.push_back(scale / z);
    }
  if (inverse.size() < 2) return 0.0;
  const auto at = [&inverse](double share) {
    auto nth = inverse.begin() + static_cast<std::ptrdiff_t>(share * (inverse.size() - 1));
    std::nth_element(inverse.begin(), nth, inverse.end());
    return *nth;
  };
  const double spread = at(0.98) - at(0.02);
  double baseline = 0.0;
  for (const Pose& pose : state.poses)
    baseline = std::max(baseline, pose.Centre().head<2>().norm());
  return state.camera.f * baseline * spread;
}

nlohmann::json ToJson(const ParallaxSplit& split) {
  return {{"along_px", split.along_px}, {"across_px", split.across_px}};
}

}  // namespace

ParallaxSplit SplitByParallax(const FeatureTracks& tracks, const std::vector<bool>& use,
                              const SparseState& state) {
  // Each observation's parallax direction: its residual's derivative by its
  // track's inverse depth, by central differences (relative step).
  constexpr double kStep = 1e-4;
  SparseState nearer = state, farther = state;
  for (double& w : nearer.inverse_depths) w *= 1.0 + kStep;
  for (double& w : farther.inverse_depths) w *= 1.0 - kStep;
  const std::vector<Eigen::Matrix2Xd> residuals = ObservationResiduals(tracks, state),
                                      to_nearer = ObservationResiduals(tracks, nearer),
                                      to_farther = ObservationResiduals(tracks, farther);
  double along = 0.0, across = 0.0;
  int count = 0;
  for (int i = 0; i < tracks.num_frames(); ++i) {
    if (i == tracks.reference) continue;
    for (int j = 0; j < tracks.num_tracks(); ++j) {
      const Eigen::Vector2d parallax = to_nearer[i].col(j) - to_farther[i].col(j);
      if (!use[j] || !(parallax.norm() > 0.0)) continue;
      const Eigen::Vector2d direction = parallax.normalized();
      const Eigen::Vector2d residual = residuals[i].col(j);
      along += std::pow(residual.dot(direction), 2);
      across += std::pow(residual.x() * direction.y() - residual.y() * direction.x(), 2);
      ++count;
    }
  }
  if (count == 0) return {};
  return {std::sqrt(along / count), std::sqrt(across / count)};
}

std::optional<PinnedDepth> PinDepthToTruth(const Burst& burst, const cv::Mat& truth,
                                           const cv::Mat& mask, const SparseReconstruction& sparse,
                                           const SparseOptions& sparse_options,
                                           const DenseOptions& dense,
                                           const PinnedDepthOptions& options) {
  options.Check();
  const FeatureTracks& tracks = sparse.tracks;
  std::vector<bool> use = sparse.inliers;
  std::vector<double> truth_inverse(tracks.num_tracks(), 0.0), estimated, given;
  for (int j = 0; j < tracks.num_tracks(); ++j) {
    if (!use[j]) continue;
    const double z = FlatTruthDepth(truth, tracks.pixels[tracks.reference].col(j), options);
    use[j] = z > 0.0 && sparse.state.inverse_depths[j] > 0.0;
    if (!use[j]) continue;
    truth_inverse[j] = 1.0 / z;
    estimated.push_back(sparse.state.inverse_depths[j]);
    given.push_back(truth_inverse[j]);
  }
  if (static_cast<int>(given.size()) < options.min_tracks) return std::nullopt;
  BundleAdjustmentOptions adjust = sparse_options.bundle_adjustment;
  adjust.fix_intrinsics = true;
  adjust.estimate_readout =
      sparse_options.rolling_shutter.mode == RollingShutterOptions::Mode::kEstimate;
  if (!sparse.state.angular_velocities.empty())
    adjust.angular_velocity_sigma_px = sparse_options.angular_velocity_sigma_px;
  PinnedDepth out;
  out.pinned_tracks = use;
  out.free = out.pinned = sparse.state;
  out.free_rms_px = RunBundleAdjustment(tracks, use, &out.free, adjust).rms_reprojection_px;
  const double scale = WindowMedian(estimated) / WindowMedian(given);
  for (int j = 0; j < tracks.num_tracks(); ++j)
    if (use[j]) out.pinned.inverse_depths[j] = scale * truth_inverse[j];
  adjust.hold_inverse_depths = true;
  out.pinned_rms_px = RunBundleAdjustment(tracks, use, &out.pinned, adjust).rms_reprojection_px;
  out.camera_at_truth = out.pinned;
  adjust.fix_intrinsics = false;
  RunBundleAdjustment(tracks, use, &out.camera_at_truth, adjust);
  out.free_median_px = MedianTrackError(tracks, use, out.free);
  out.pinned_median_px = MedianTrackError(tracks, use, out.pinned);
  out.free_split = SplitByParallax(tracks, use, out.free);
  out.pinned_split = SplitByParallax(tracks, use, out.pinned);
  const Burst kept = SelectFrames(burst, sparse.feature_stats.kept_frames);
  out.free_depth = DenseOver(kept, truth, mask, tracks, use, out.free, dense);
  out.pinned_depth = DenseOver(kept, truth, mask, tracks, use, out.pinned, dense);
  out.parallax_range_px = ParallaxRangePx(truth, mask, out.pinned, scale);
  return out;
}

int PinnedDepth::tracks() const {
  return static_cast<int>(std::count(pinned_tracks.begin(), pinned_tracks.end(), true));
}

nlohmann::json ToJson(const PinnedDepth& pinned) {
  return {{"tracks", pinned.tracks()},
          {"free_rms_px", pinned.free_rms_px},
          {"pinned_rms_px", pinned.pinned_rms_px},
          {"free_median_px", pinned.free_median_px},
          {"pinned_median_px", pinned.pinned_median_px},
          {"free_split", ToJson(pinned.free_split)},
          {"pinned_split", ToJson(pinned.pinned_split)},
          {"camera_at_truth",
           {{"f", pinned.camera_at_truth.camera.f},
            {"k1", pinned.camera_at_truth.camera.k1},
            {"k2", pinned.camera_at_truth.camera.k2},
            {"readout", pinned.camera_at_truth.readout}}},
          {"free_readout", pinned.free.readout},
          {"pinned_readout", pinned.pinned.readout},
          {"free_depth", ToJson(pinned.free_depth)},
          {"pinned_depth", ToJson(pinned.pinned_depth)},
          {"parallax_range_px", pinned.parallax_range_px}};
}

}  // namespace dfsm
