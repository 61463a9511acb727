#include "core/sparse/sparse_reconstruction.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "core/io/stage_timer.h"

namespace dfsm {
namespace {

std::string Format(double value, int precision = 2) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(precision);
  out << value;
  return out.str();
}

double RobustSigma(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return 1.4826 * values[values.size() / 2];
}

// Contrast of the scene, not of the sensor: the grey-level spread of the
// reference frame after a blur that averages sensor noise away (noise of
// sigma 1.5 leaves ~0.2 grey levels; any photographed scene leaves tens).
double SceneContrast(const cv::Mat& gray) {
  cv::Mat blurred;
  cv::GaussianBlur(gray, blurred, cv::Size(), 2.0);
  cv::Scalar mean, stddev;
  cv::meanStdDev(blurred, mean, stddev);
  return stddev[0];
}

// Below this scene contrast (grey levels) the corners found are sensor noise.
constexpr double kMinSceneContrast = 2.0;

// Why fewer than min_tracks corners were tracked through the burst, in
// measured terms: no texture at all, too little of it, or texture that the
// tracker lost (motion beyond small motion, blur).
ReconstructionError TooFewTracks(const cv::Mat& reference, const SparseReconstruction& sparse,
                                 const SparseOptions& options) {
  const GridedFeatureStats& stats = sparse.feature_stats;
  const double contrast = SceneContrast(reference);
  const std::string need = " (need >= " + std::to_string(options.min_tracks) + ")";
  const std::string measured = "; scene contrast " + Format(contrast, 1) + " grey levels";
  if (contrast < kMinSceneContrast || stats.corners == 0)
    return ReconstructionError("too few tracks: no texture: " + std::to_string(stats.corners) +
                               " of " + std::to_string(stats.cells) + " cells hold a corner, " +
                               std::to_string(stats.tracks) + " tracked" + need + measured +
                               " (need >= " + Format(kMinSceneContrast, 1) + ")");
  if (stats.corners < options.min_tracks)
    return ReconstructionError(
        "too few tracks: too little texture: " + std::to_string(stats.corners) + " of " +
        std::to_string(stats.cells) + " cells hold a corner, " + std::to_string(stats.tracks) +
        " tracked" + need + measured);
  return ReconstructionError("too few tracks: " + std::to_string(stats.tracks) + " of " +
                             std::to_string(stats.corners) + " corners survived tracking" + need +
                             ": motion too large or blur" + measured);
}

}  // namespace

InitMode ParseInitMode(const std::string& name) {
  if (name == "rank1") return InitMode::kRankOne;
  if (name == "naive") return InitMode::kNaive;
  throw std::invalid_argument("init must be \"rank1\" or \"naive\", not \"" + name + "\"");
}

const char* InitModeName(InitMode mode) { return mode == InitMode::kRankOne ? "rank1" : "naive"; }

std::vector<double> SparseReconstruction::InlierInverseDepths() const {
  std::vector<double> inverse_depths;
  for (size_t j = 0; j < inliers.size(); ++j)
    if (inliers[j]) inverse_depths.push_back(state.inverse_depths[j]);
  return inverse_depths;
}

SparseReconstruction ReconstructSparse(const std::vector<cv::Mat>& frames, int reference,
                                       const SparseOptions& options) {
  if (frames.size() < 3)
    throw ReconstructionError("a burst needs at least 3 frames, got " +
                              std::to_string(frames.size()));
  SparseReconstruction sparse;
  StageTimer timer(&sparse.timings_ms);
  const int width = frames[reference].cols, height = frames[reference].rows;

  sparse.tracks = TrackGridedFeatures(frames, reference, options.features, &sparse.feature_stats);
  timer.Lap("features");
  const int tracked = sparse.tracks.num_tracks();
  if (tracked < options.min_tracks) throw TooFewTracks(frames[reference], sparse, options);
  const double parallax = sparse.tracks.MedianMaxDisplacement();
  if (parallax < options.min_parallax_px)
    throw ReconstructionError("insufficient parallax: median track motion " + Format(parallax) +
                              " px (need >= " + Format(options.min_parallax_px) + " px)");

  const CameraModel initial = CameraModel::Initial(width, height);
  SparseState& state = sparse.state;
  state.camera = initial;
  std::vector<bool> use(tracked, true);
  if (options.init == InitMode::kRankOne) {
    const std::vector<Eigen::Matrix3d> rotations = EstimateRotations(sparse.tracks, initial);
    timer.Lap("rotation");
    sparse.rank_one = RankOneInit(sparse.tracks, initial, rotations, options.rank_one);
    timer.Lap("rank1");
    if (!sparse.rank_one.ok)
      throw ReconstructionError("rank-1 initialization failed: fewer than 3 consistent tracks");
    state.poses = sparse.rank_one.poses;
    state.inverse_depths = sparse.rank_one.inverse_depths;
    use = sparse.rank_one.inliers;
  } else {
    // The reference code's start: no motion, random inverse depths.
    state.poses.assign(frames.size(), Pose{});
    std::mt19937_64 random(options.naive_seed);
    std::uniform_real_distribution<double> uniform(0.01, 1.0);
    state.inverse_depths.resize(tracked);
    for (double& w : state.inverse_depths) w = uniform(random);
    timer.Lap("rotation");
    timer.Lap("rank1");
  }
  if (std::count(use.begin(), use.end(), true) < options.min_tracks)
    throw ReconstructionError("too few consistent tracks after outlier rejection: " +
                              std::to_string(std::count(use.begin(), use.end(), true)) +
                              " (need >= " + std::to_string(options.min_tracks) + ")");

  sparse.bundle_adjustment =
      RunBundleAdjustment(sparse.tracks, use, &state, options.bundle_adjustment);
  // Judge every track again under the adjusted camera: tracks the initial
  // camera made look wrong come back, tracks that do not fit go, and a short
  // re-run from the adjusted state settles the set. A track on a depth edge
  // (a T-junction, not a point of the scene) fits to a few tenths of a pixel
  // and still pulls f against k1/k2, so the bound is tight and the rounds
  // repeat until the set stops changing.
  const BundleAdjustmentSummary first = sparse.bundle_adjustment;
  for (int round = 0; round < options.outlier_rounds; ++round) {
    const std::vector<double> errors = TrackReprojectionErrors(sparse.tracks, state);
    std::vector<double> used_errors;
    for (int j = 0; j < tracked; ++j)
      if (use[j]) used_errors.push_back(errors[j]);
    const double threshold = std::max(options.outlier_px, 4.0 * RobustSigma(used_errors));
    std::vector<bool> kept(tracked);
    for (int j = 0; j < tracked; ++j)
      kept[j] = errors[j] <= threshold && state.inverse_depths[j] > 0.0;
    if (kept == use || std::count(kept.begin(), kept.end(), true) < options.min_tracks) break;
    use = kept;
    const int iterations = sparse.bundle_adjustment.iterations;
    sparse.bundle_adjustment =
        RunBundleAdjustment(sparse.tracks, use, &state, options.bundle_adjustment);
    sparse.bundle_adjustment.iterations += iterations;
    sparse.bundle_adjustment.initial_cost = first.initial_cost;
  }
  // The residual depends on w_j T_i only, so (w, T) -> (-w, -T) is an exact
  // symmetry the adjustment may cross: choose the sign that puts most tracks
  // in front of the camera. A track still behind it is no point of the scene,
  // whatever its reprojection error.
  int behind = 0, used = 0;
  for (int j = 0; j < tracked; ++j)
    if (use[j]) ++used, behind += state.inverse_depths[j] < 0.0;
  if (2 * behind > used) {
    for (double& w : state.inverse_depths) w = -w;
    for (Pose& pose : state.poses) pose.T = -pose.T;
  }
  for (int j = 0; j < tracked; ++j)
    if (use[j] && !(state.inverse_depths[j] > 0.0)) use[j] = false;
  if (std::count(use.begin(), use.end(), true) < options.min_tracks)
    throw ReconstructionError("too few consistent tracks after bundle adjustment: " +
                              std::to_string(std::count(use.begin(), use.end(), true)) +
                              " in front of the camera, need >= " +
                              std::to_string(options.min_tracks) + " (median track motion " +
                              Format(parallax) + " px: too little baseline to separate depths)");
  sparse.bundle_adjustment.init = InitModeName(options.init);
  sparse.inliers = use;
  timer.Lap("bundle_adjustment");

  // A burst that does not observe the camera can still leave a distortion that
  // folds the image over itself: no depth map can be made through it.
  const CameraModel& camera = state.camera;
  const double corner_px = std::hypot(std::max(camera.cx, camera.width - camera.cx),
                                      std::max(camera.cy, camera.height - camera.cy));
  for (int step = 1; step <= 64; ++step) {
    const double r = corner_px * step / 64.0 / camera.f;
    const double r2 = r * r;
    if (1.0 + 3.0 * camera.k1 * r2 + 5.0 * camera.k2 * r2 * r2 <= 0.0)
      throw ReconstructionError(
          "camera not observable: the estimated distortion (k1 " + Format(camera.k1, 4) + ", k2 " +
          Format(camera.k2, 4) + ") folds the image over " + Format(corner_px * step / 64.0) +
          " px from the centre; the burst needs more hand rotation or more texture");
  }

  // A global scale is free: report depths with median inverse depth 1.
  std::vector<double> inverse_depths = sparse.InlierInverseDepths();
  std::nth_element(inverse_depths.begin(), inverse_depths.begin() + inverse_depths.size() / 2,
                   inverse_depths.end());
  const double median = inverse_depths[inverse_depths.size() / 2];
  if (!(median > 0.0) || !std::isfinite(state.camera.f) || state.camera.f <= 0.0)
    throw ReconstructionError("bundle adjustment diverged (median inverse depth " +
                              Format(median, 6) + ", f " + Format(state.camera.f) + ")");
  for (double& w : state.inverse_depths) w /= median;
  for (Pose& pose : state.poses) pose.T *= median;
  return sparse;
}

}  // namespace dfsm
