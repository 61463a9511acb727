#include "core/sparse/sparse_reconstruction.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>

#include "core/camera/rolling_shutter.h"
#include "core/io/stage_timer.h"
#include "core/sparse/fixed_text.h"
#include "core/sparse/lens_relief_shift.h"
#include "core/sparse/robust_sigma.h"
#include "core/sparse/rolling_shutter_rectification.h"

namespace dfsm {
namespace {

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

// A readout below this (frame intervals) moves no observation by a tenth of a
// pixel at a degree of tremor: the rank-1 start stands.
constexpr double kMinRectifiedReadout = 0.05;
// Rounds of rectifying and re-initializing (measured at 1080p, readout 0.6:
// rotation error 0.35 -> 0.052 -> 0.014 -> 0.006 deg).
constexpr int kRectificationRounds = 3;
// Readouts the adjustment also restarts from where it estimates the readout.
// A readout and a top-to-bottom tilt of the scene trade against each other
// when the camera moves up and down (docs/sparse.md, "The readout's sigma,
// and TUM window 18-27"): the adjustment has two minima there, and which it
// reaches depends on the start. Starts nearer than kSameReadoutStart to one
// already tried return to the same minimum and are skipped.
constexpr double kReadoutStarts[] = {0.5, 1.0};
constexpr double kSameReadoutStart = 0.15;
// Iterations of the first adjustment where it estimates the readout: it only
// measures the readout for the restarts, which converge from there in a few
// iterations. On phone bursts it used to crawl along a narrow valley to its
// 100-iteration cap (1080p: cost 2717 at the start, 36 after 30 iterations,
// 26.3 after 100), while the restart from its readout reached 12.2 in 8.
// Where it measures no readout it goes on to the full budget, since no
// restart follows (docs/sparse.md, "The first adjustment's budget").
constexpr int kMeasuringIterations = 30;

// Focal starts beyond these (fractions of max(width, height)) are no camera:
// 0.2 is a 136 deg view across the longer side, 5 a 11 deg one.
constexpr double kFocalStartRange[] = {0.2, 5.0};
// A later focal start replaces the solution so far where its truncated cost
// is lower by more than this fraction. Two starts that reach the same minimum
// differ by far less, and the earlier one (the paper's guess first) stands.
constexpr double kFocalStartGain = 0.01;
// A later focal start is probed: its rotations, rank-1 start and first
// adjustment, stopped after this many iterations, and only the winner goes on
// to the readout restarts and outlier rounds. A start near the camera reaches
// its minimum in a few iterations; one far from it (0.6 on a normal lens)
// crawled along the f valley to the 100-iteration cap in every run and round
// (370 ms more at 1080p), to lose anyway.
constexpr int kFocalStartIterations = 20;

// The outlier rule of the rounds after the adjustment: the tracks of `use`
// (and of `use` only, their inverse depths being the adjusted ones) within
// max(outlier_px, 4 robust sigmas) of the state's reprojection, in front.
std::vector<bool> KeptTracks(const FeatureTracks& tracks, const SparseState& state,
                             const std::vector<bool>& use, const SparseOptions& options) {
  const std::vector<double> errors = TrackReprojectionErrors(tracks, state);
  std::vector<double> used_errors;
  for (size_t j = 0; j < errors.size(); ++j)
    if (use[j]) used_errors.push_back(errors[j]);
  const double threshold = std::max(options.outlier_px, 4.0 * RobustSigma(used_errors));
  std::vector<bool> kept(errors.size());
  for (size_t j = 0; j < errors.size(); ++j)
    kept[j] = errors[j] <= threshold && state.inverse_depths[j] > 0.0;
  return kept;
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
  const std::string measured = "; scene contrast " + FixedText(contrast, 1) + " grey levels";
  if (contrast < kMinSceneContrast || stats.corners == 0)
    return ReconstructionError("too few tracks: no texture: " + std::to_string(stats.corners) +
                               " of " + std::to_string(stats.cells) + " cells hold a corner, " +
                               std::to_string(stats.tracks) + " tracked" + need + measured +
                               " (need >= " + FixedText(kMinSceneContrast, 1) + ")");
  if (stats.corners < options.min_tracks)
    return ReconstructionError(
        "too few tracks: too little texture: " + std::to_string(stats.corners) + " of " +
        std::to_string(stats.cells) + " cells hold a corner, " + std::to_string(stats.tracks) +
        " tracked" + need + measured);
  return ReconstructionError("too few tracks: " + std::to_string(stats.tracks) + " of " +
                             std::to_string(stats.corners) + " corners survived tracking" + need +
                             ": motion too large or blur" + measured);
}

// The adjustment's fit to every track, inliers or not, robustly: each track's
// squared RMS reprojection error, capped at threshold^2, summed. A solution
// that keeps fewer tracks pays for the ones it loses, and one that fits its
// inliers more closely gains; a median alone preferred, on a wide-lens burst,
// a camera 10 % off that fitted fewer tracks to a larger mean error.
double TruncatedTrackCost(const FeatureTracks& tracks, const SparseState& state, double threshold) {
  double cost = 0.0;
  for (const double error : TrackReprojectionErrors(tracks, state))
    cost += std::isfinite(error) ? std::min(error * error, threshold * threshold)
                                 : threshold * threshold;
  return cost;
}

void CheckFocalStarts(const std::vector<double>& starts) {
  if (starts.empty())
    throw std::invalid_argument(
        "focal_starts: at least one start is needed (1: the paper's guess)");
  for (const double start : starts)
    if (!(start >= kFocalStartRange[0] && start <= kFocalStartRange[1]))
      throw std::invalid_argument("focal_starts: " + FixedText(start) + " is outside [" +
                                  FixedText(kFocalStartRange[0]) + ", " +
                                  FixedText(kFocalStartRange[1]) + "] of max(width, height)");
}

double MedianTrackError(const FeatureTracks& tracks, const SparseState& state) {
  std::vector<double> errors = TrackReprojectionErrors(tracks, state);
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

}  // namespace

InitMode ParseInitMode(const std::string& name) {
  if (name == "rank1") return InitMode::kRankOne;
  if (name == "naive") return InitMode::kNaive;
  throw std::invalid_argument("init must be \"rank1\" or \"naive\", not \"" + name + "\"");
}

const char* InitModeName(InitMode mode) { return mode == InitMode::kRankOne ? "rank1" : "naive"; }

KnownCalibrationMode ParseKnownCalibrationMode(const std::string& name) {
  if (name == "fixed") return KnownCalibrationMode::kFixed;
  if (name == "prior") return KnownCalibrationMode::kPrior;
  throw std::invalid_argument("calibration mode must be \"fixed\" or \"prior\", not \"" + name +
                              "\"");
}

const char* KnownCalibrationModeName(KnownCalibrationMode mode) {
  return mode == KnownCalibrationMode::kFixed ? "fixed" : "prior";
}

std::vector<double> SparseReconstruction::InlierInverseDepths() const {
  std::vector<double> inverse_depths;
  for (size_t j = 0; j < inliers.size(); ++j)
    if (inliers[j]) inverse_depths.push_back(state.inverse_depths[j]);
  return inverse_depths;
}

namespace {

// Everything after the tracking (`sparse` holds the tracks): the
// initialization, the adjustment and its outlier rounds, the verdict and any
// fallback, for a burst of width x height; `measure_lens_relief`: also
// SparseReconstruction::lens_relief_shift (one adjustment more), which the
// known-fit check's run of the burst alone does not read.
SparseReconstruction AdjustTracks(SparseReconstruction sparse, int width, int height,
                                  const SparseOptions& options, bool measure_lens_relief) {
  StageTimer timer(&sparse.timings_ms);
  const int tracked = sparse.tracks.num_tracks();
  const double parallax = sparse.tracks.MedianMaxDisplacement();

  // A known calibration starts (and, fixed, stays) where the file puts it; it
  // also makes the rotations of the initialization exact instead of assuming
  // f = max(w, h) and no distortion.
  const CameraModel initial =
      options.known ? options.known->camera : CameraModel::Initial(width, height);
  if (options.known && (initial.width != width || initial.height != height))
    throw ReconstructionError("the known calibration is for " + std::to_string(initial.width) +
                              "x" + std::to_string(initial.height) + ", the burst is " +
                              std::to_string(width) + "x" + std::to_string(height));
  BundleAdjustmentOptions ba_options = options.bundle_adjustment;
  if (options.known) {
    if (options.known->mode == KnownCalibrationMode::kFixed) {
      ba_options.fix_intrinsics = true;
    } else {
      ba_options.known_f_sigma_percent = options.known->f_sigma_percent;
      ba_options.known_distortion_sigma_px = options.known->distortion_sigma_px;
    }
    sparse.calibration_used =
        options.known->mode == KnownCalibrationMode::kFixed ? "known-fixed" : "known-prior";
  }
  options.rolling_shutter.Check();
  if (options.rolling_shutter.mode == RollingShutterOptions::Mode::kEstimate)
    ba_options.estimate_readout = true;
  SparseState& state = sparse.state;
  std::vector<bool> use;
  const auto run_adjustment = [&](const BundleAdjustmentOptions& ba) {
    sparse.bundle_adjustment = RunBundleAdjustment(sparse.tracks, use, &state, ba);
    BundleAdjustmentRun run;
    run.iterations = sparse.bundle_adjustment.iterations;
    run.converged = sparse.bundle_adjustment.converged;
    run.tracks = static_cast<int>(std::count(use.begin(), use.end(), true));
    run.final_cost = sparse.bundle_adjustment.final_cost;
    sparse.runs.push_back(run);
  };
  const bool rank_one = options.init == InitMode::kRankOne;
  // A rolling shutter: the global-shutter rank-1 start is far off under a
  // phone's readout (rolling_shutter_rectification.h), so the adjustment
  // starts from a rank-1 initialization of the tracks rectified with the
  // readout: the known one at once; an estimated one after a first
  // adjustment has measured it, keeping whichever adjustment fits better.
  const auto rectified_start = [&](const CameraModel& camera, const std::vector<Pose>& poses,
                                   double readout, SparseState* start,
                                   std::vector<bool>* start_use) {
    RankOneResult init =
        RectifiedRankOneInit(sparse.tracks, camera, poses, readout, kRectificationRounds,
                             options.rank_one, options.frame_times);
    if (!init.ok || std::count(init.inliers.begin(), init.inliers.end(), true) < options.min_tracks)
      return false;
    start->camera = camera;
    start->poses = init.poses;
    start->inverse_depths = init.inverse_depths;
    start->readout = readout;
    start->frame_times = options.frame_times;
    *start_use = init.inliers;
    sparse.rank_one = std::move(init);
    return true;
  };
  // After the first adjustment: the rest of its budget where it measured no
  // readout, the readout restarts, the outlier rounds.
  const auto finish = [&](const BundleAdjustmentOptions& adjust, int measured_iterations) {
    if (measured_iterations < adjust.max_iterations && !sparse.bundle_adjustment.converged &&
        std::abs(state.readout) < kMinRectifiedReadout)
      run_adjustment(adjust);  // no restart follows: this adjustment is the result
    if (rank_one && adjust.estimate_readout && std::abs(state.readout) >= kMinRectifiedReadout) {
      // Restarts from the readout the first adjustment measured and from
      // kReadoutStarts, each rectified with the first adjustment's camera and
      // poses; the best fit over every track wins, not each start's own
      // inliers: a wrong minimum fits its few inliers as well as the right one
      // fits many. Where the first adjustment measured no readout (a global
      // shutter), none is tried: those restarts cost 0.6-0.9 s per burst and
      // changed no ideal burst.
      const SparseState measured = state;
      std::vector<double> starts = {measured.readout};
      for (const double start : kReadoutStarts)
        if (std::none_of(starts.begin(), starts.end(),
                         [&](double tried) { return std::abs(tried - start) < kSameReadoutStart; }))
          starts.push_back(start);
      double best_error = MedianTrackError(sparse.tracks, state);
      for (const double start : starts) {
        SparseState restart;
        std::vector<bool> restart_use;
        const RankOneResult best_rank_one = sparse.rank_one;
        if (!rectified_start(measured.camera, measured.poses, start, &restart, &restart_use))
          continue;
        const SparseState best = state;
        const std::vector<bool> best_use = use;
        const BundleAdjustmentSummary best_summary = sparse.bundle_adjustment;
        state = restart;
        use = restart_use;
        run_adjustment(adjust);
        const double error = MedianTrackError(sparse.tracks, state);
        if (error < best_error) {
          best_error = error;
        } else {
          state = best;
          use = best_use;
          sparse.bundle_adjustment = best_summary;
          sparse.rank_one = best_rank_one;
        }
      }
    }
    // Judge every track again under the adjusted camera: tracks the initial
    // camera made look wrong come back, tracks that do not fit go, and a short
    // re-run from the adjusted state settles the set. A track on a depth edge
    // (a T-junction, not a point of the scene) fits to a few tenths of a pixel
    // and still pulls f against k1/k2, so the bound is tight and the rounds
    // repeat until the set stops changing.
    const BundleAdjustmentSummary first = sparse.bundle_adjustment;
    for (int round = 0; round < options.outlier_rounds; ++round) {
      const std::vector<bool> kept = KeptTracks(sparse.tracks, state, use, options);
      if (kept == use || std::count(kept.begin(), kept.end(), true) < options.min_tracks) break;
      use = kept;
      run_adjustment(adjust);
      sparse.bundle_adjustment.initial_cost = first.initial_cost;
    }
  };
  // The initialization and the first adjustment from `start_camera`, then
  // (unless `probe`) the rest; throws ReconstructionError.
  const auto solve_from = [&](const CameraModel& start_camera, bool timed,
                              const BundleAdjustmentOptions& adjust, bool probe) {
    state.camera = start_camera;
    state.frame_times = options.frame_times;
    state.readout = options.rolling_shutter.mode == RollingShutterOptions::Mode::kKnown
                        ? options.rolling_shutter.readout
                        : 0.0;
    use.assign(tracked, true);
    if (options.init == InitMode::kRankOne) {
      const std::vector<Eigen::Matrix3d> rotations = EstimateRotations(sparse.tracks, start_camera);
      if (timed) timer.Lap("rotation");
      sparse.rank_one = RankOneInit(sparse.tracks, start_camera, rotations, options.rank_one);
      if (timed) timer.Lap("rank1");
      if (!sparse.rank_one.ok)
        throw ReconstructionError("rank-1 initialization failed: fewer than 3 consistent tracks");
      state.poses = sparse.rank_one.poses;
      state.inverse_depths = sparse.rank_one.inverse_depths;
      use = sparse.rank_one.inliers;
    } else {
      // The reference code's start: no motion, random inverse depths.
      state.poses.assign(sparse.tracks.num_frames(), Pose{});
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

    if (rank_one && std::abs(state.readout) >= kMinRectifiedReadout)
      rectified_start(state.camera, state.poses, state.readout, &state, &use);
    BundleAdjustmentOptions measuring = adjust;
    if (rank_one && adjust.estimate_readout)
      measuring.max_iterations = std::min(measuring.max_iterations, kMeasuringIterations);
    run_adjustment(measuring);
    if (!probe) finish(adjust, measuring.max_iterations);
  };
  // Each focal start runs the whole chain above, and a later one replaces the
  // solution so far only where it fits every track clearly better
  // (SparseOptions::focal_starts); a known camera and the naive start are
  // started once. A start that finds no solution is passed over; where none
  // does, the first one's reason is the error.
  const bool restarts = !options.known && options.init == InitMode::kRankOne;
  const size_t starts = restarts ? options.focal_starts.size() : 1;
  struct Solution {
    SparseState state;
    std::vector<bool> use;
    BundleAdjustmentSummary summary;
    RankOneResult rank_one;
    std::vector<BundleAdjustmentRun> runs;
    double start_f = 0.0;
    bool probed = false;  // a later start: its first adjustment alone, capped
    double cost = std::numeric_limits<double>::infinity();
  };
  std::optional<Solution> best;
  std::optional<ReconstructionError> first_error;
  for (size_t n = 0; n < starts; ++n) {
    CameraModel start = initial;
    if (restarts) start.f = options.focal_starts[n] * initial.f;
    sparse.runs.clear();
    try {
      BundleAdjustmentOptions adjust = ba_options;
      if (n > 0) adjust.max_iterations = std::min(adjust.max_iterations, kFocalStartIterations);
      solve_from(start, /*timed=*/n == 0, adjust, /*probe=*/n > 0);
    } catch (const ReconstructionError& error) {
      if (n == 0) first_error = error;
      continue;
    }
    const double cost = TruncatedTrackCost(sparse.tracks, state, options.outlier_px);
    if (!best || cost < (1.0 - kFocalStartGain) * best->cost)
      best = Solution{state, use, sparse.bundle_adjustment, sparse.rank_one, sparse.runs, start.f,
                      n > 0, cost};
    if (n == 0) timer.Lap("bundle_adjustment");
  }
  if (!best) throw *first_error;
  if (starts > 1) timer.Lap("focal_starts");
  state = std::move(best->state);
  use = std::move(best->use);
  sparse.bundle_adjustment = std::move(best->summary);
  sparse.rank_one = std::move(best->rank_one);
  sparse.runs = std::move(best->runs);
  const double start_f = best->start_f;
  // A probed start that won goes on from there with the whole budget.
  if (best->probed) finish(ba_options, kFocalStartIterations);
  if (options.known && options.known->mode == KnownCalibrationMode::kPrior &&
      options.known->also_self_calibrate) {
    SparseState self = state;
    SparseReconstruction::SelfEstimate estimate;
    BundleAdjustmentOptions self_options = options.bundle_adjustment;
    self_options.estimate_readout = ba_options.estimate_readout;
    const BundleAdjustmentSummary summary =
        RunBundleAdjustment(sparse.tracks, use, &self, self_options, &estimate.uncertainty);
    CalibrationEvidence self_evidence;
    self_evidence.tracks = static_cast<int>(std::count(use.begin(), use.end(), true));
    self_evidence.rms_reprojection_px = summary.rms_reprojection_px;
    self_evidence.median_track_motion_px = parallax;
    estimate.camera = self.camera;
    estimate.verdict =
        JudgeCalibration(self.camera, estimate.uncertainty, self_evidence, options.quality);
    sparse.self_estimate = estimate;
  }
  // The residual depends on w_j T_i only, so (w, T) -> (-w, -T) is an exact
  // symmetry the adjustment may cross: choose the sign that puts most tracks
  // in front of the camera. A track still behind it is no point of the scene,
  // whatever its reprojection error.
  // Also after a fallback refit, which can cross the same symmetry.
  const auto settle_sign = [&]() {
    int behind = 0, used = 0;
    for (int j = 0; j < tracked; ++j)
      if (use[j]) ++used, behind += state.inverse_depths[j] < 0.0;
    if (2 * behind > used) {
      for (double& w : state.inverse_depths) w = -w;
      for (Pose& pose : state.poses) pose.T = -pose.T;
    }
    for (int j = 0; j < tracked; ++j)
      if (use[j] && !(state.inverse_depths[j] > 0.0)) use[j] = false;
  };
  settle_sign();
  if (std::count(use.begin(), use.end(), true) < options.min_tracks)
    throw ReconstructionError("too few consistent tracks after bundle adjustment: " +
                              std::to_string(std::count(use.begin(), use.end(), true)) +
                              " in front of the camera, need >= " +
                              std::to_string(options.min_tracks) + " (median track motion " +
                              FixedText(parallax) + " px: too little baseline to separate depths)");
  sparse.bundle_adjustment.init = InitModeName(options.init);
  sparse.inliers = use;
  // The covariance once, at the final state and tracks: an adjustment of no
  // iterations only evaluates (computing it in every outlier round cost 60 %
  // of a run each, sparse_bench BM_BundleAdjustment/uncertainty).
  const auto estimate_uncertainty = [&](const BundleAdjustmentOptions& ba) {
    BundleAdjustmentOptions evaluate_only = ba;
    evaluate_only.max_iterations = 0;
    SparseState at = state;
    RunBundleAdjustment(sparse.tracks, use, &at, evaluate_only, &sparse.uncertainty);
  };
  estimate_uncertainty(ba_options);
  timer.Lap("uncertainty");

  // The verdict on the estimated calibration, then the camera the later stages
  // get: a folding lens model, or one the dense stage cannot invert, is
  // replaced (the known calibration where there is one, else no distortion)
  // and the poses are refitted under it, so that depth never fails because of
  // an absurd calibration, and the result says so.
  CalibrationEvidence evidence;
  evidence.tracks = static_cast<int>(std::count(use.begin(), use.end(), true));
  evidence.rms_reprojection_px = sparse.bundle_adjustment.rms_reprojection_px;
  evidence.median_track_motion_px = parallax;
  evidence.intrinsics_estimated = !ba_options.fix_intrinsics;
  sparse.verdict = JudgeCalibration(state.camera, sparse.uncertainty, evidence, options.quality);
  std::string unusable;
  double fold_px = 0.0;
  if (!RadialModelIsMonotone(state.camera, &fold_px))
    unusable = "folds the image over itself " + FixedText(fold_px, 0) + " px from the centre";
  else if (options.camera_usable && !options.camera_usable(state.camera, &unusable))
    unusable = unusable.empty() ? "is refused by the dense stage" : unusable;
  if (!unusable.empty()) {
    sparse.rejected_camera = state.camera;
    const SparseState estimated = state;
    const std::vector<bool> estimated_use = use;
    // The fallbacks in order: the known calibration where there is one; else
    // k1 alone (k2 = 0: most of a wide lens's distortion, whose k2 went
    // negative to stand in for higher terms the model lacks), then none.
    // Each is refitted from the estimate, and the first the dense stage can
    // use is kept.
    struct Fallback {
      CameraModel camera;
      BundleAdjustmentOptions options;
      const char* name;
      const char* what;
    };
    std::vector<Fallback> fallbacks;
    if (options.known) {
      fallbacks.push_back({options.known->camera, ba_options, "fallback-known",
                           "the known calibration was used instead"});
      fallbacks.back().options.fix_intrinsics = true;
    } else {
      CameraModel start = CameraModel::Initial(width, height);
      if (estimated.camera.f > 0.0 && std::isfinite(estimated.camera.f))
        start.f = estimated.camera.f;
      CameraModel k1_only = start;
      if (std::isfinite(estimated.camera.k1)) k1_only.k1 = estimated.camera.k1;
      fallbacks.push_back({k1_only, ba_options, "fallback-k1", "refitted with k2 = 0 instead"});
      fallbacks.back().options.distortion_terms = std::min(1, ba_options.distortion_terms);
      fallbacks.push_back({start, ba_options, "fallback-k0", "refitted with k1 = k2 = 0 instead"});
      fallbacks.back().options.distortion_terms = 0;
    }
    for (size_t n = 0; n < fallbacks.size(); ++n) {
      const Fallback& fallback = fallbacks[n];
      state = estimated;
      use = estimated_use;
      state.camera = fallback.camera;
      run_adjustment(fallback.options);
      settle_sign();
      std::string refused;
      const bool last = n + 1 == fallbacks.size();
      if (!last && (!RadialModelIsMonotone(state.camera, &fold_px) ||
                    (options.camera_usable && !options.camera_usable(state.camera, &refused))))
        continue;
      sparse.calibration_used = fallback.name;
      sparse.warnings.push_back("the estimated calibration (f " + FixedText(estimated.camera.f, 1) +
                                " px, k1 " + FixedText(estimated.camera.k1, 4) + ", k2 " +
                                FixedText(estimated.camera.k2, 4) + ") " + unusable + "; " +
                                fallback.what + ", and depth was computed with that camera");
      sparse.inliers = use;
      estimate_uncertainty(fallback.options);
      break;
    }
    if (std::count(use.begin(), use.end(), true) < options.min_tracks)
      throw ReconstructionError(
          "too few consistent tracks after refitting without the "
          "rejected calibration: " +
          std::to_string(std::count(use.begin(), use.end(), true)));
  }
  if (sparse.verdict.quality != CalibrationQuality::kReliable && evidence.intrinsics_estimated)
    sparse.warnings.push_back(std::string("calibration ") +
                              CalibrationQualityName(sparse.verdict.quality) + ": " +
                              sparse.verdict.reasons.front());

  if (measure_lens_relief && !ba_options.fix_intrinsics &&
      ba_options.known_distortion_sigma_px == 0.0 && ba_options.distortion_terms == 2 &&
      !sparse.rejected_camera)
    sparse.lens_relief_shift = LensReliefShift(sparse.tracks, use, state, ba_options);
  timer.Lap("lens_check");

  // A global scale is free: report depths with median inverse depth 1.
  std::vector<double> inverse_depths = sparse.InlierInverseDepths();
  std::nth_element(inverse_depths.begin(), inverse_depths.begin() + inverse_depths.size() / 2,
                   inverse_depths.end());
  const double median = inverse_depths[inverse_depths.size() / 2];
  if (!(median > 0.0) || !std::isfinite(state.camera.f) || state.camera.f <= 0.0)
    throw ReconstructionError("bundle adjustment diverged (median inverse depth " +
                              FixedText(median, 6) + ", f " + FixedText(state.camera.f) + ")");
  for (double& w : state.inverse_depths) w /= median;
  for (Pose& pose : state.poses) pose.T *= median;
  sparse.bundle_adjustment.start_f = start_f;  // also where a fallback refitted from it
  return sparse;
}

}  // namespace

SparseReconstruction ReconstructSparse(const std::vector<cv::Mat>& frames, int reference,
                                       const SparseOptions& options) {
  if (frames.size() < 3)
    throw ReconstructionError("a burst needs at least 3 frames, got " +
                              std::to_string(frames.size()));
  CheckFrameTimes(options.frame_times, static_cast<int>(frames.size()));
  CheckFocalStarts(options.focal_starts);
  SparseReconstruction tracked;
  StageTimer timer(&tracked.timings_ms);
  tracked.tracks = TrackGridedFeatures(frames, reference, options.features, &tracked.feature_stats);
  timer.Lap("features");
  if (tracked.tracks.num_tracks() < options.min_tracks)
    throw TooFewTracks(frames[reference], tracked, options);
  const double parallax = tracked.tracks.MedianMaxDisplacement();
  if (parallax < options.min_parallax_px)
    throw ReconstructionError("insufficient parallax: median track motion " + FixedText(parallax) +
                              " px (need >= " + FixedText(options.min_parallax_px) + " px)");
  const int width = frames[reference].cols, height = frames[reference].rows;
  const bool check_known =
      options.known && options.known->check_fit && options.max_known_fit_ratio > 0.0;
  SparseReconstruction sparse =
      AdjustTracks(check_known ? tracked : std::move(tracked), width, height, options,
                   /*measure_lens_relief=*/true);
  if (check_known) {
    // The same tracks calibrated by the burst alone: a camera that fits them
    // much better than the known one (more tracks, or a smaller error) says
    // the known calibration, or the motion model under it, does not hold
    // here. A geometry wrong as a whole agrees with its own tracks, so
    // nothing later would notice; a wrong camera also rejects tracks, which
    // is why the comparison starts from the tracking, not from the known
    // camera's solution.
    StageTimer check_timer(&sparse.timings_ms);
    SparseOptions alone = options;
    alone.known.reset();
    SparseReconstruction::KnownFit fit;
    fit.known_tracks =
        static_cast<int>(std::count(sparse.inliers.begin(), sparse.inliers.end(), true));
    fit.known_rms_px = sparse.bundle_adjustment.rms_reprojection_px;
    try {
      const SparseReconstruction free = AdjustTracks(std::move(tracked), width, height, alone,
                                                     /*measure_lens_relief=*/false);
      fit.free_tracks =
          static_cast<int>(std::count(free.inliers.begin(), free.inliers.end(), true));
      fit.free_rms_px = free.bundle_adjustment.rms_reprojection_px;
      fit.free_camera = free.state.camera;
      fit.free_quality = free.verdict.quality;
      sparse.known_fit = fit;
      if (!fit.Fits(options.max_known_fit_ratio)) {
        const std::string reason =
            "known calibration does not fit this burst: under it " +
            std::to_string(fit.known_tracks) + " tracks fit to " + FixedText(fit.known_rms_px) +
            " px RMS, calibrated by the burst alone " + std::to_string(fit.free_tracks) +
            " tracks to " + FixedText(fit.free_rms_px) + " px (f " +
            FixedText(fit.free_camera.f, 1) + " px)";
        sparse.warnings.push_back(reason +
                                  "; the calibration, or the motion model under it, does not "
                                  "hold here and the depth may be wrong as a whole");
        // The camera used is no longer one the burst vouches for.
        if (sparse.verdict.quality == CalibrationQuality::kReliable)
          sparse.verdict.quality = CalibrationQuality::kUncertain;
        sparse.verdict.reasons.insert(sparse.verdict.reasons.begin(), reason);
      }
    } catch (const ReconstructionError&) {
      // The burst cannot calibrate itself: nothing to compare the known camera with.
    }
    check_timer.Lap("known_fit");
  }
  return sparse;
}

}  // namespace dfsm
