#include "core/sparse/sparse_reconstruction.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "core/camera/rolling_shutter.h"
#include "core/io/frame_times.h"
#include "core/io/stage_timer.h"
#include "core/parallel/parallel_for.h"
#include "core/sparse/adjustment_starts.h"
#include "core/sparse/camera_relief_disagreement.h"
#include "core/sparse/fixed_text.h"
#include "core/sparse/lens_relief_shift.h"

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
  std::string reached;
  for (size_t i = 0; i < stats.reached.size(); ++i)
    reached += (i ? ", " : "") + std::to_string(stats.reached[i]);
  const std::string left_out = stats.left_out.empty()
                                   ? ""
                                   : " (through the " + std::to_string(stats.kept_frames.size()) +
                                         " frames kept; " + std::to_string(stats.left_out.size()) +
                                         " left out)";
  return ReconstructionError("too few tracks: " + std::to_string(stats.tracks) + " of " +
                             std::to_string(stats.corners) + " corners survived tracking" +
                             left_out + need + ": motion too large or blur" + measured +
                             "; corners that reached each frame: " + reached);
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

const char* CalibrationSourceName(CalibrationSource source) {
  switch (source) {
    case CalibrationSource::kSelf:
      return "self";
    case CalibrationSource::kKnownFixed:
      return "known-fixed";
    case CalibrationSource::kKnownPrior:
      return "known-prior";
    case CalibrationSource::kFallbackKnown:
      return "fallback-known";
    case CalibrationSource::kFallbackK1:
      return "fallback-k1";
    case CalibrationSource::kFallbackK0:
      return "fallback-k0";
  }
  return "?";
}

const char* StartKindName(StartKind kind) {
  switch (kind) {
    case StartKind::kFocal:
      return "focal";
    case StartKind::kNaive:
      return "naive";
    case StartKind::kGiven:
      return "given";
    case StartKind::kReadout:
      return "readout";
  }
  return "?";
}

const char* StartOutcomeName(StartOutcome outcome) {
  switch (outcome) {
    case StartOutcome::kChosen:
      return "chosen";
    case StartOutcome::kBeaten:
      return "beaten";
    case StartOutcome::kFailed:
      return "failed";
  }
  return "?";
}

// Focal starts beyond these (fractions of max(width, height)) are no camera:
// 0.2 is a 136 deg view across the longer side, 5 a 11 deg one.
constexpr double kFocalStartRange[] = {0.2, 5.0};

void SparseOptions::Check() const {
  features.Check();
  rank_one.Check();
  bundle_adjustment.Check();
  bootstrap.Check();
  rolling_shutter.Check();
  quality.Check();
  if (focal_starts.empty())
    throw std::invalid_argument(
        "focal_starts: at least one start is needed (1: the paper's guess)");
  for (const double start : focal_starts)
    if (!(start >= kFocalStartRange[0] && start <= kFocalStartRange[1]))
      throw std::invalid_argument("focal_starts: " + FixedText(start) + " is outside [" +
                                  FixedText(kFocalStartRange[0]) + ", " +
                                  FixedText(kFocalStartRange[1]) + "] of max(width, height)");
  if (min_tracks < 3)
    throw std::invalid_argument("min_tracks must be >= 3, got " + std::to_string(min_tracks));
  if (!(min_parallax_px >= 0.0)) throw std::invalid_argument("min_parallax_px must be >= 0");
  if (!(outlier_px > 0.0)) throw std::invalid_argument("outlier_px must be > 0");
  if (!(angular_velocity_sigma_px >= 0.0))
    throw std::invalid_argument(
        "angular_velocity_sigma_px must be >= 0 (0: the line between frame poses)");
  if (outlier_rounds < 0)
    throw std::invalid_argument("outlier_rounds must be >= 0 (0: none), got " +
                                std::to_string(outlier_rounds));
  if (reweight_rounds < 0)
    throw std::invalid_argument(
        "reweight_rounds must be >= 0 (0: every track weighs the same), got " +
        std::to_string(reweight_rounds));
  if (!(min_track_weight > 0.0 && min_track_weight <= 1.0))
    throw std::invalid_argument("min_track_weight must be in (0, 1], got " +
                                FixedText(min_track_weight));
  if (!(max_known_fit_ratio == 0.0 || max_known_fit_ratio >= 1.0))
    throw std::invalid_argument("max_known_fit_ratio must be 0 (no check) or >= 1, got " +
                                FixedText(max_known_fit_ratio));
  if (!(min_known_inlier_share >= 0.0 && min_known_inlier_share <= 1.0))
    throw std::invalid_argument("min_known_inlier_share must be in [0, 1] (0: never), got " +
                                FixedText(min_known_inlier_share));
}

std::vector<double> SparseReconstruction::InlierInverseDepths() const {
  std::vector<double> inverse_depths;
  for (size_t j = 0; j < inliers.size(); ++j)
    if (inliers[j]) inverse_depths.push_back(state.inverse_depths[j]);
  return inverse_depths;
}

std::optional<CameraModel> SparseReconstruction::DebiasedCamera() const {
  if (self_estimate) return Debiased(self_estimate->camera, OwnCalibrationBias());
  if (calibration_used == CalibrationSource::kSelf)
    return Debiased(state.camera, OwnCalibrationBias());
  return std::nullopt;
}

std::optional<CameraModel> SparseReconstruction::OwnCamera() const {
  if (self_estimate) return self_estimate->camera;
  if (calibration_used == CalibrationSource::kSelf) return state.camera;
  if (DroppedLensTerms() && rejected_camera) return rejected_camera;
  return std::nullopt;
}

const CalibrationUncertainty* SparseReconstruction::OwnUncertainty() const {
  if (self_estimate) return &self_estimate->uncertainty;
  if (calibration_used == CalibrationSource::kSelf) return &uncertainty;
  return nullptr;
}

bool SparseReconstruction::DroppedLensTerms() const {
  return calibration_used == CalibrationSource::kFallbackK1 ||
         calibration_used == CalibrationSource::kFallbackK0;
}

namespace {

// The adjustment's options under `known` (may be null: the burst calibrates
// itself): the known calibration held, or given as a prior of its widths;
// the readout estimated where the rolling shutter asks for it; the rows
// turning at each frame's own velocity under a camera held, or from a given
// start with turning rows (may be null).
BundleAdjustmentOptions AdjustmentOptionsFor(const SparseOptions& options,
                                             const KnownCalibration* known,
                                             const GivenStart* given = nullptr) {
  BundleAdjustmentOptions adjust = options.bundle_adjustment;
  if (known && known->mode == KnownCalibrationMode::kFixed) {
    adjust.fix_intrinsics = true;
    adjust.angular_velocity_sigma_px = options.angular_velocity_sigma_px;
  }
  if (given && given->turning_rows)
    adjust.angular_velocity_sigma_px = options.angular_velocity_sigma_px;
  if (known && known->mode == KnownCalibrationMode::kPrior) {
    adjust.known_f_sigma_percent = known->f_sigma_percent;
    adjust.known_distortion_sigma_px = known->distortion_sigma_px;
  }
  if (options.rolling_shutter.mode == RollingShutterOptions::Mode::kEstimate)
    adjust.estimate_readout = true;
  return adjust;
}

// The burst's own calibration beside a known prior (KnownCalibration::
// also_self_calibrate): the solution adjusted once more without the prior;
// `relief_disagreement`: SparseReconstruction::camera_relief_disagreement.
SparseReconstruction::SelfEstimate EstimateAlone(const FeatureTracks& tracks,
                                                 const std::vector<bool>& use,
                                                 const SparseState& solution,
                                                 const SparseOptions& options,
                                                 double* relief_disagreement) {
  SparseReconstruction::SelfEstimate estimate;
  const BundleAdjustmentOptions alone = AdjustmentOptionsFor(options, nullptr);
  SparseState state = solution;
  const BundleAdjustmentSummary summary =
      RunBundleAdjustment(tracks, use, &state, alone, &estimate.uncertainty);
  *relief_disagreement =
      CameraReliefDisagreement(solution.inverse_depths, use, state.inverse_depths, use);
  CalibrationEvidence evidence;
  evidence.tracks = CountUsed(use);
  evidence.rms_reprojection_px = summary.rms_reprojection_px;
  evidence.median_track_motion_px = tracks.MedianMaxDisplacement();
  estimate.camera = state.camera;
  estimate.bias = MeasureBiasIfItMatters(tracks, use, state, alone, options.bootstrap);
  estimate.verdict =
      JudgeCalibration(state.camera, estimate.uncertainty, evidence, options.quality);
  return estimate;
}

// The residual depends on w_j T_i only, so (w, T) -> (-w, -T) is an exact
// symmetry the adjustment may cross (a fallback refit too): the sign that
// puts most tracks in front of the camera is chosen. A track still behind it
// is no point of the scene, whatever its reprojection error.
void SettleSign(SparseState* state, std::vector<bool>* use) {
  int behind = 0, used = 0;
  for (size_t j = 0; j < use->size(); ++j)
    if ((*use)[j]) ++used, behind += state->inverse_depths[j] < 0.0;
  if (2 * behind > used) {
    for (double& w : state->inverse_depths) w = -w;
    for (Pose& pose : state->poses) pose.T = -pose.T;
  }
  for (size_t j = 0; j < use->size(); ++j)
    if ((*use)[j] && !(state->inverse_depths[j] > 0.0)) (*use)[j] = false;
}

// The covariance at `state`: an adjustment of no iterations only evaluates
// (computing it in every outlier round cost 60 % of a run each, sparse_bench
// BM_BundleAdjustment/uncertainty).
CalibrationUncertainty UncertaintyAt(const FeatureTracks& tracks, const std::vector<bool>& use,
                                     SparseState state, BundleAdjustmentOptions adjust) {
  adjust.max_iterations = 0;
  CalibrationUncertainty uncertainty;
  RunBundleAdjustment(tracks, use, &state, adjust, &uncertainty);
  return uncertainty;
}

// Why the later stages cannot use `camera` (a folding lens model, or one the
// dense stage cannot invert); empty where they can.
std::string UnusableCamera(const CameraModel& camera, const SparseOptions& options) {
  double fold_px = 0.0;
  if (!RadialModelIsMonotone(camera, &fold_px))
    return "folds the image over itself " + FixedText(fold_px, 0) + " px from the centre";
  std::string why;
  if (options.camera_usable && !options.camera_usable(camera, &why))
    return why.empty() ? "is refused by the dense stage" : why;
  return "";
}

// The covariance at the solution and, where `check_lens`, the lens relief
// check: they read the solution and nothing of each other, so they run side
// by side (each single-threaded); the lens check's wall time beyond the
// covariance's goes to the "uncertainty" lap.
void MeasureSolution(const AdjustmentAttempt& solved, const BundleAdjustmentOptions& adjust,
                     bool check_lens, StageTimer* timer, SparseReconstruction* sparse) {
  double uncertainty_ms = 0.0;
  std::vector<std::function<void()>> checks{[&] {
    const auto start = std::chrono::steady_clock::now();
    sparse->uncertainty = UncertaintyAt(sparse->tracks, solved.use, solved.state, adjust);
    uncertainty_ms = MillisecondsBetween(start);
  }};
  if (check_lens)
    checks.push_back([&] {
      sparse->lens_relief_shift = LensReliefShift(sparse->tracks, solved.use, solved.state, adjust);
    });
  const auto checks_start = std::chrono::steady_clock::now();
  RunInParallel(checks);
  timer->Lap("uncertainty", MillisecondsBetween(checks_start) - uncertainty_ms);
}

// A camera the tracks are refitted under where the estimate is unusable.
struct Fallback {
  CameraModel camera;
  BundleAdjustmentOptions options;
  CalibrationSource source;
  const char* what;
};

// The fallbacks in order: the known calibration where there is one; else k1
// alone (k2 = 0: most of a wide lens's distortion, whose k2 went negative to
// stand in for higher terms the model lacks), then none.
std::vector<Fallback> FallbacksFor(const CameraModel& estimated, const SparseOptions& options,
                                   const BundleAdjustmentOptions& adjust, int width, int height) {
  std::vector<Fallback> fallbacks;
  if (options.known) {
    fallbacks.push_back({options.known->camera, adjust, CalibrationSource::kFallbackKnown,
                         "the known calibration was used instead"});
    fallbacks.back().options.fix_intrinsics = true;
    return fallbacks;
  }
  CameraModel start = CameraModel::Initial(width, height);
  if (estimated.f > 0.0 && std::isfinite(estimated.f)) start.f = estimated.f;
  CameraModel k1_only = start;
  if (std::isfinite(estimated.k1)) k1_only.k1 = estimated.k1;
  fallbacks.push_back(
      {k1_only, adjust, CalibrationSource::kFallbackK1, "refitted with k2 = 0 instead"});
  fallbacks.back().options.distortion_terms = std::min(1, adjust.distortion_terms);
  fallbacks.push_back(
      {start, adjust, CalibrationSource::kFallbackK0, "refitted with k1 = k2 = 0 instead"});
  fallbacks.back().options.distortion_terms = 0;
  return fallbacks;
}

// The estimated camera is `unusable`: the tracks are refitted from the
// estimate under each fallback in turn, and the first the later stages can
// use (the last one whatever it is) is kept, with a warning that says so.
// Depth then never fails because of an absurd calibration.
void RefitUnderFallback(const std::string& unusable, const SparseOptions& options,
                        const BundleAdjustmentOptions& adjust, int width, int height,
                        AdjustmentAttempt* solved, SparseReconstruction* sparse) {
  sparse->rejected_camera = solved->state.camera;
  const SparseState estimated = solved->state;
  const std::vector<bool> estimated_use = solved->use;
  const std::vector<Fallback> fallbacks =
      FallbacksFor(estimated.camera, options, adjust, width, height);
  for (size_t n = 0; n < fallbacks.size(); ++n) {
    const Fallback& fallback = fallbacks[n];
    solved->state = estimated;
    solved->use = estimated_use;
    solved->state.camera = fallback.camera;
    solved->Adjust(sparse->tracks, fallback.options);
    SettleSign(&solved->state, &solved->use);
    if (n + 1 < fallbacks.size() && !UnusableCamera(solved->state.camera, options).empty())
      continue;
    sparse->calibration_used = fallback.source;
    sparse->warnings.push_back("the estimated calibration (f " + FixedText(estimated.camera.f, 1) +
                               " px, k1 " + FixedText(estimated.camera.k1, 4) + ", k2 " +
                               FixedText(estimated.camera.k2, 4) + ") " + unusable + "; " +
                               fallback.what + ", and depth was computed with that camera");
    sparse->inliers = solved->use;
    sparse->uncertainty =
        UncertaintyAt(sparse->tracks, solved->use, solved->state, fallback.options);
    break;
  }
  if (CountUsed(solved->use) < options.min_tracks)
    throw ReconstructionError(
        "too few consistent tracks after refitting without the rejected calibration: " +
        std::to_string(CountUsed(solved->use)));
}

// A global scale is free: the depths are reported with median inverse depth 1.
void ScaleToUnitMedianInverseDepth(SparseReconstruction* sparse) {
  SparseState& result = sparse->state;
  std::vector<double> inverse_depths = sparse->InlierInverseDepths();
  std::nth_element(inverse_depths.begin(), inverse_depths.begin() + inverse_depths.size() / 2,
                   inverse_depths.end());
  const double median = inverse_depths[inverse_depths.size() / 2];
  if (!(median > 0.0) || !std::isfinite(result.camera.f) || result.camera.f <= 0.0)
    throw ReconstructionError("bundle adjustment diverged (median inverse depth " +
                              FixedText(median, 6) + ", f " + FixedText(result.camera.f) + ")");
  for (double& w : result.inverse_depths) w /= median;
  for (Pose& pose : result.poses) pose.T *= median;
}

// The mirror's cost over the solution's below which the mirror is kept.
constexpr double kMirrorBetterRatio = 0.99;

// `state` with its relief mirrored about the median inverse depth of the
// tracks `use` marks, the translations reversed.
SparseState MirroredRelief(const SparseState& state, const std::vector<bool>& use) {
  std::vector<double> used;
  for (size_t j = 0; j < use.size(); ++j)
    if (use[j]) used.push_back(state.inverse_depths[j]);
  std::nth_element(used.begin(), used.begin() + used.size() / 2, used.end());
  const double median = used[used.size() / 2];
  SparseState mirrored = state;
  for (double& w : mirrored.inverse_depths) w = std::max(2.0 * median - w, 0.05 * median);
  for (Pose& pose : mirrored.poses) pose.T = -pose.T;
  return mirrored;
}

// The warning of a solution whose mirror was kept, `cost_ratio` the mirror's
// cost over the first solution's.
std::string MirroredReliefWarning(double cost_ratio) {
  return "depth order: the mirrored relief (near and far exchanged) fits the tracks better than "
         "the first solution (cost x" +
         FixedText(cost_ratio, 3) + ") and was kept";
}

// SparseOptions::mirrored_relief: the solution and its mirror adjusted with
// the intrinsics (and readout) held, the mirror's kept where its cost is
// clearly lower, with the camera of the solution; the summary keeps the
// solution's runs with the mirror's final cost and RMS.
void TryMirroredRelief(const FeatureTracks& tracks, const BundleAdjustmentOptions& adjust,
                       AdjustmentAttempt* solved, SparseReconstruction* sparse) {
  if (CountUsed(solved->use) < 3) return;
  BundleAdjustmentOptions held = adjust;
  held.fix_intrinsics = true;
  held.estimate_readout = false;
  SparseState solution = solved->state;
  const BundleAdjustmentSummary at_solution =
      RunBundleAdjustment(tracks, solved->use, &solution, held);
  SparseState mirrored = MirroredRelief(solved->state, solved->use);
  const BundleAdjustmentSummary from_mirror =
      RunBundleAdjustment(tracks, solved->use, &mirrored, held);
  sparse->mirrored_relief_cost_ratio =
      from_mirror.final_cost / std::max(at_solution.final_cost, 1e-300);
  // A mirror that came back to the solution ends within the solver's
  // tolerance of its cost, above or below: only a clearly lower cost is
  // another, better minimum.
  if (!(sparse->mirrored_relief_cost_ratio < kMirrorBetterRatio)) return;
  // Kept as the held adjustment left it: adjusting the intrinsics again from
  // the mirror moved f by 8 % on the flower clip's naive start
  // (docs/experiments/007-relief-flip.md).
  SettleSign(&mirrored, &solved->use);
  solved->state = std::move(mirrored);
  solved->summary.final_cost = from_mirror.final_cost;
  solved->summary.rms_reprojection_px = from_mirror.rms_reprojection_px;
  sparse->mirrored_relief_kept = true;
  sparse->warnings.push_back(MirroredReliefWarning(sparse->mirrored_relief_cost_ratio));
}

// Where each frame's own angular velocity left fewer than
// SparseOptions::min_tracks in front of the camera, the adjustment runs
// again with the rows on the line between frame poses, and says so: the
// velocities' three parameters a frame are too many for a burst with few
// frames and tracks left (fr1/rpy 13-22: 5 frames tracked, 15 tracks in
// front; docs/experiments/024).
void AdjustOnTheLineInstead(const FeatureTracks& tracks, const CameraModel& initial,
                            const SparseOptions& options, StageTimer* timer, SharedWork* beside,
                            const GivenStart* given, BundleAdjustmentOptions* adjust,
                            AdjustmentAttempt* solved, SparseReconstruction* sparse) {
  const int in_front = CountUsed(solved->use);
  adjust->angular_velocity_sigma_px = 0.0;
  *solved = AdjustFromStarts(tracks, initial, options, *adjust, timer, beside, given);
  SettleSign(&solved->state, &solved->use);
  sparse->warnings.push_back(
      "rows on the line between frame poses: with each frame's own angular velocity only " +
      std::to_string(in_front) +
      " tracks stayed in front of the camera (need >= " + std::to_string(options.min_tracks) + ")");
}

// What a burst whose tracks the adjustment could not keep most likely
// suffers from, by its median track motion `parallax_px`: below
// kLittleParallaxPx a small motion separates depths too weakly for the
// tracking noise (the phone VGA sweep's 0.25 deg bursts move about 1.4 px);
// above it the baseline is there, and the tracks disagree on the scene
// (fr1/rpy 14-23, 29 px: five of ten frames blurred).
std::string WhyTracksDisagree(double parallax_px) {
  constexpr double kLittleParallaxPx = 1.0;
  const std::string motion = "median track motion " + FixedText(parallax_px) + " px";
  if (parallax_px < kLittleParallaxPx)
    return motion + ": too little baseline to separate depths; move the camera a little more";
  return motion +
         ": the tracks do not fit one still scene seen from one moving camera "
         "(motion blur, a jolt, or something moving in the view)";
}

// Everything after the tracking (`sparse` holds the tracks): the
// initialization, the adjustment and its outlier rounds, the verdict and any
// fallback, for a burst of width x height; `measure_lens_relief`: also
// SparseReconstruction::lens_relief_shift (one adjustment more), which the
// known-fit check's run of the burst alone does not read.
SparseReconstruction AdjustTracks(SparseReconstruction sparse, int width, int height,
                                  const SparseOptions& options, bool measure_lens_relief,
                                  SharedWork* beside, const GivenStart* given = nullptr) {
  StageTimer timer(&sparse.timings_ms, options.progress);
  const double parallax = sparse.tracks.MedianMaxDisplacement();
  // A known calibration starts (and, fixed, stays) where the file puts it; it
  // also makes the rotations of the initialization exact instead of assuming
  // f = max(w, h) and no distortion. A burst that calibrates itself from a
  // given start starts from that start's camera.
  const CameraModel initial = options.known ? options.known->camera
                              : given       ? given->state.camera
                                            : CameraModel::Initial(width, height);
  if (options.known && (initial.width != width || initial.height != height))
    throw ReconstructionError("the known calibration is for " + std::to_string(initial.width) +
                              "x" + std::to_string(initial.height) + ", the burst is " +
                              std::to_string(width) + "x" + std::to_string(height));
  if (options.known)
    sparse.calibration_used = options.known->mode == KnownCalibrationMode::kFixed
                                  ? CalibrationSource::kKnownFixed
                                  : CalibrationSource::kKnownPrior;
  BundleAdjustmentOptions adjust =
      AdjustmentOptionsFor(options, options.known ? &*options.known : nullptr, given);
  AdjustmentAttempt solved =
      AdjustFromStarts(sparse.tracks, initial, options, adjust, &timer, beside, given);
  SettleSign(&solved.state, &solved.use);
  if (CountUsed(solved.use) < options.min_tracks && adjust.angular_velocity_sigma_px > 0.0 &&
      options.known)
    AdjustOnTheLineInstead(sparse.tracks, initial, options, &timer, beside, given, &adjust, &solved,
                           &sparse);
  if (options.mirrored_relief) TryMirroredRelief(sparse.tracks, adjust, &solved, &sparse);
  timer.Lap("mirrored_relief");
  // From the solution as reported: the mirror, where it was kept.
  if (options.known && options.known->mode == KnownCalibrationMode::kPrior &&
      options.known->also_self_calibrate) {
    sparse.self_estimate = EstimateAlone(sparse.tracks, solved.use, solved.state, options,
                                         &sparse.camera_relief_disagreement);
    timer.Lap("self_estimate");
  }
  if (CountUsed(solved.use) < options.min_tracks)
    throw ReconstructionError(
        "too few consistent tracks after bundle adjustment: " +
        std::to_string(CountUsed(solved.use)) + " of " +
        std::to_string(sparse.tracks.num_tracks()) + " in front of the camera, need >= " +
        std::to_string(options.min_tracks) + " (" + WhyTracksDisagree(parallax) + ")");
  sparse.inliers = solved.use;
  // The camera is judged before the covariance; its time, a millisecond or
  // so, goes to the "uncertainty" lap. The lens check runs where the burst
  // calibrated its own lens and keeps it.
  const std::string unusable = UnusableCamera(solved.state.camera, options);
  const bool check_lens = measure_lens_relief && options.measure_lens_relief &&
                          !adjust.fix_intrinsics && adjust.known_distortion_sigma_px == 0.0 &&
                          adjust.distortion_terms == 2 && unusable.empty();
  MeasureSolution(solved, adjust, check_lens, &timer, &sparse);
  // The verdict on the estimated calibration, then an unusable one replaced.
  CalibrationEvidence evidence;
  evidence.tracks = CountUsed(solved.use);
  evidence.rms_reprojection_px = solved.summary.rms_reprojection_px;
  evidence.median_track_motion_px = parallax;
  evidence.intrinsics_estimated = !adjust.fix_intrinsics;
  sparse.verdict =
      JudgeCalibration(solved.state.camera, sparse.uncertainty, evidence, options.quality);
  if (!unusable.empty())
    RefitUnderFallback(unusable, options, adjust, width, height, &solved, &sparse);
  if (sparse.verdict.quality != CalibrationQuality::kReliable && evidence.intrinsics_estimated)
    sparse.warnings.push_back(std::string("calibration ") +
                              CalibrationQualityName(sparse.verdict.quality) + ": " +
                              sparse.verdict.reasons.front());
  timer.Lap("lens_check");
  // Where the solution started, also where a fallback refitted from it.
  solved.summary.start_f = solved.start_f;
  solved.summary.init = InitModeName(solved.init);
  solved.summary.from_self_calibration = solved.given && options.known;
  sparse.state = std::move(solved.state);
  sparse.bundle_adjustment = std::move(solved.summary);
  sparse.rank_one = std::move(solved.rank_one);
  sparse.runs = std::move(solved.runs);
  sparse.starts = std::move(solved.starts);
  ScaleToUnitMedianInverseDepth(&sparse);
  return sparse;
}

// The same tracks calibrated by the burst alone (no known camera, no
// bootstrap: its camera is compared or started from, not reported or
// fused); empty where the burst cannot calibrate itself. Its laps are not
// the stage's: the caller reports the whole as one.
std::optional<SparseReconstruction> CalibrateAlone(const SparseReconstruction& tracked, int width,
                                                   int height, const SparseOptions& options,
                                                   SharedWork* beside) {
  SparseOptions alone = options;
  alone.known.reset();
  alone.bootstrap.replicas = 0;
  alone.progress = nullptr;
  try {
    return AdjustTracks(tracked, width, height, alone, /*measure_lens_relief=*/false, beside);
  } catch (const ReconstructionError&) {
    return std::nullopt;
  }
}

GivenStart OwnSolutionStart(const SparseReconstruction& free) {
  return GivenStart{free.state, free.inliers, ParseInitMode(free.bundle_adjustment.init)};
}

// A known calibration without the fit check (SparseOptions::
// min_known_inlier_share): adjusted under it; where that keeps too few of
// the tracks, again with the burst's own solution as one more start (which
// the starts made under it then have to beat, as in the checked case).
SparseReconstruction AdjustUncheckedKnown(SparseReconstruction tracked, int width, int height,
                                          const SparseOptions& options, SharedWork* beside) {
  if (!(options.min_known_inlier_share > 0.0))
    return AdjustTracks(std::move(tracked), width, height, options,
                        /*measure_lens_relief=*/true, beside);
  const auto first_start = std::chrono::steady_clock::now();
  SparseReconstruction first =
      AdjustTracks(tracked, width, height, options, /*measure_lens_relief=*/true, beside);
  if (!(CountUsed(first.inliers) < options.min_known_inlier_share * tracked.tracks.num_tracks()))
    return first;
  const double first_ms = MillisecondsBetween(first_start);
  const auto alone_start = std::chrono::steady_clock::now();
  const std::optional<SparseReconstruction> free =
      CalibrateAlone(tracked, width, height, options, beside);
  if (!free) return first;
  const double alone_ms = MillisecondsBetween(alone_start);
  const GivenStart own = OwnSolutionStart(*free);
  try {
    SparseReconstruction again = AdjustTracks(std::move(tracked), width, height, options,
                                              /*measure_lens_relief=*/true, beside, &own);
    again.timings_ms.emplace_back("known_first_try", first_ms);
    again.timings_ms.emplace_back("known_fit", alone_ms);
    return again;
  } catch (const ReconstructionError&) {
    return first;  // the same starts and one more: not expected, but the first stands
  }
}

// A known calibration with the fit check (SparseOptions::
// max_known_fit_ratio, KnownCalibration::check_fit).
SparseReconstruction AdjustCheckedKnown(SparseReconstruction tracked, int width, int height,
                                        const SparseOptions& options, SharedWork* beside) {
  // The same tracks calibrated by the burst alone, first: a camera that fits
  // them much better than the known one (more tracks, or a smaller error)
  // says the known calibration, or the motion model under it, does not hold
  // here. A geometry wrong as a whole agrees with its own tracks, so nothing
  // later would notice; a wrong camera also rejects tracks, which is why the
  // comparison starts from the tracking, not from the known camera's
  // solution. Its solution is also one more start of the adjustment under
  // the known camera: the starts made under it (rank-1, naive) can all end
  // in a minimum that rejects a third of the tracks, where the burst's own
  // solution, its camera replaced by the known one, converges to one that
  // fits them all (docs/experiments/135-given-start-known.md).
  const auto check_start = std::chrono::steady_clock::now();
  const std::optional<SparseReconstruction> free =
      CalibrateAlone(tracked, width, height, options, beside);
  const double check_ms = MillisecondsBetween(check_start);
  ReportProgress(options.progress, "known_fit", 1, 1);
  std::optional<GivenStart> own;
  if (free) own = OwnSolutionStart(*free);
  SparseReconstruction sparse =
      AdjustTracks(std::move(tracked), width, height, options,
                   /*measure_lens_relief=*/true, beside, own ? &*own : nullptr);
  if (free) {
    SparseReconstruction::KnownFit fit;
    fit.known_tracks = CountUsed(sparse.inliers);
    fit.known_rms_px = sparse.bundle_adjustment.rms_reprojection_px;
    fit.free_tracks = CountUsed(free->inliers);
    fit.free_rms_px = free->bundle_adjustment.rms_reprojection_px;
    fit.free_camera = free->state.camera;
    fit.free_quality = free->verdict.quality;
    fit.fits = fit.Fits(options.max_known_fit_ratio);
    sparse.known_fit = fit;
    sparse.camera_relief_disagreement = CameraReliefDisagreement(
        sparse.state.inverse_depths, sparse.inliers, free->state.inverse_depths, free->inliers);
    if (!fit.fits) {
      const std::string reason =
          "known calibration does not fit this burst: under it " +
          std::to_string(fit.known_tracks) + " tracks fit to " + FixedText(fit.known_rms_px) +
          " px RMS, calibrated by the burst alone " + std::to_string(fit.free_tracks) +
          " tracks to " + FixedText(fit.free_rms_px) + " px (f " + FixedText(fit.free_camera.f, 1) +
          " px)";
      sparse.warnings.push_back(reason +
                                "; the calibration, or the motion model under it, does not "
                                "hold here and the depth may be wrong as a whole");
      // The camera used is no longer one the burst vouches for.
      if (sparse.verdict.quality == CalibrationQuality::kReliable)
        sparse.verdict.quality = CalibrationQuality::kUncertain;
      sparse.verdict.reasons.insert(sparse.verdict.reasons.begin(), reason);
    }
  }
  sparse.timings_ms.emplace_back("known_fit", check_ms);
  return sparse;
}

// Whether a self-calibrated solution on the line between frame poses is
// refined with each frame's own angular velocity: a readout, and a
// calibration the burst observes (SparseOptions::angular_velocity_sigma_px).
bool RowsTurnWithinFrames(const SparseReconstruction& line, const SparseOptions& options) {
  return options.angular_velocity_sigma_px > 0.0 &&
         std::abs(line.state.readout) >= kMinEffectiveReadout &&
         line.calibration_used == CalibrationSource::kSelf &&
         line.verdict.quality != CalibrationQuality::kDegenerate;
}

// The bias the tracks' noise gives a self-calibrated solution's intrinsics
// (bootstrap_bias.h; lap "bias"), measured once, on the solution reported,
// where they are the burst's own: not a fallback's camera. `adjust`: the
// adjustment that reached the solution. The solution stays as it is: its
// depth is best with the camera that fits its tracks best.
void MeasureIntrinsicsBias(const SparseOptions& options, const BundleAdjustmentOptions& adjust,
                           SparseReconstruction* sparse) {
  if (sparse->calibration_used != CalibrationSource::kSelf) return;
  const auto start = std::chrono::steady_clock::now();
  sparse->intrinsics_bias = MeasureBiasIfItMatters(sparse->tracks, sparse->inliers, sparse->state,
                                                   adjust, options.bootstrap);
  sparse->timings_ms.emplace_back("bias", MillisecondsBetween(start));
  ReportProgress(options.progress, "bias", 1, 1);
}

// The line's solution, refined with each frame's own angular velocity from
// `own` (that solution with turning rows: the only start); empty where too
// few tracks stay in front of the camera. The line's solution has been
// checked against its mirrored relief, and a refinement from it stays in its
// basin: the mirror is not tried again, and the line's check is reported
// (docs/experiments/027-one-bias-one-mirror.md).
std::optional<SparseReconstruction> RefineWithTurningRows(SparseReconstruction tracked,
                                                          const SparseReconstruction& line,
                                                          const GivenStart& own, int width,
                                                          int height, const SparseOptions& options,
                                                          SharedWork* beside) {
  // One lap for the whole refinement: its own laps repeat the line's.
  SparseOptions refine = options;
  refine.progress = nullptr;
  refine.mirrored_relief = false;
  try {
    SparseReconstruction turning = AdjustTracks(std::move(tracked), width, height, refine,
                                                /*measure_lens_relief=*/true, beside, &own);
    turning.mirrored_relief_cost_ratio = line.mirrored_relief_cost_ratio;
    turning.mirrored_relief_kept = line.mirrored_relief_kept;
    if (line.mirrored_relief_kept)
      turning.warnings.push_back(MirroredReliefWarning(line.mirrored_relief_cost_ratio));
    return turning;
  } catch (const ReconstructionError&) {
    return std::nullopt;
  }
}

// A burst that calibrates itself: adjusted on the line between frame poses,
// which f is found by; where that calibration is observed, the solution is
// refined with each frame's own angular velocity (a hand's path bends
// between frame poses, and the line's self-calibration takes the bend up in
// the lens terms and the readout, its translation astray:
// docs/experiments/026-velocities-where-the-calibration-is-observed.md). The
// refinement is kept unless it fails, or its calibration comes out
// degenerate (the velocities then took f's signal) or unusable: the line's
// stands. The noise bias is measured on the one kept.
SparseReconstruction AdjustSelfCalibrated(SparseReconstruction tracked, int width, int height,
                                          const SparseOptions& options, SharedWork* beside) {
  SparseReconstruction line =
      AdjustTracks(tracked, width, height, options, /*measure_lens_relief=*/true, beside);
  // The line's camera under its mirrored relief is held, not a minimum of
  // its intrinsics: no bias is measured there.
  const auto keep_line = [&] {
    if (!line.mirrored_relief_kept)
      MeasureIntrinsicsBias(options, AdjustmentOptionsFor(options, nullptr), &line);
    return std::move(line);
  };
  if (!RowsTurnWithinFrames(line, options)) return keep_line();
  const auto refine_start = std::chrono::steady_clock::now();
  GivenStart own = OwnSolutionStart(line);
  own.turning_rows = true;
  std::optional<SparseReconstruction> turning =
      RefineWithTurningRows(std::move(tracked), line, own, width, height, options, beside);
  line.timings_ms.emplace_back("angular_velocity", MillisecondsBetween(refine_start));
  ReportProgress(options.progress, "angular_velocity", 1, 1);
  if (!turning || turning->verdict.quality == CalibrationQuality::kDegenerate ||
      turning->calibration_used != CalibrationSource::kSelf)
    return keep_line();
  // What the report says of the adjustment: the line's laps, starts, runs
  // and first focal length, then the refinement's.
  turning->timings_ms = std::move(line.timings_ms);
  turning->starts.insert(turning->starts.begin(), line.starts.begin(), line.starts.end());
  turning->runs.insert(turning->runs.begin(), line.runs.begin(), line.runs.end());
  turning->bundle_adjustment.start_f = line.bundle_adjustment.start_f;
  MeasureIntrinsicsBias(options, AdjustmentOptionsFor(options, nullptr, &own), &*turning);
  return std::move(*turning);
}

// Everything after the tracking: the parallax check, then the adjustment
// as the known calibration (or none) asks.
SparseReconstruction AdjustTracked(SparseReconstruction tracked, int width, int height,
                                   const SparseOptions& options, SharedWork* beside) {
  const double parallax = tracked.tracks.MedianMaxDisplacement();
  if (parallax < options.min_parallax_px)
    throw ReconstructionError("insufficient parallax: median track motion " + FixedText(parallax) +
                              " px (need >= " + FixedText(options.min_parallax_px) +
                              " px): move the camera a little during the burst");
  SparseReconstruction sparse =
      !options.known ? AdjustSelfCalibrated(std::move(tracked), width, height, options, beside)
      : options.known->check_fit && options.max_known_fit_ratio > 0.0
          ? AdjustCheckedKnown(std::move(tracked), width, height, options, beside)
          : AdjustUncheckedKnown(std::move(tracked), width, height, options, beside);
  // A known camera the stage held is the user's word, which a long telephoto
  // or a fisheye keeps outside the plausible range; the burst's own
  // estimates (a prior's included) are judged.
  const bool held = sparse.calibration_used == CalibrationSource::kKnownFixed ||
                    sparse.calibration_used == CalibrationSource::kFallbackKnown;
  if (!held) sparse.implausible_camera = ImplausibleCamera(sparse.state.camera, options.quality);
  sparse.parallax = MeasureParallax(sparse.tracks, sparse.inliers, sparse.state,
                                    sparse.bundle_adjustment.rms_reprojection_px);
  return sparse;
}

}  // namespace

// The frames kept share at least this many times SparseOptions::min_tracks
// (GridedFeatureOptions::min_shared_tracks): the adjustment still has to
// reject the tracks that do not fit, up to half of a real window's, and keep
// min_tracks in front (docs/experiments/029-room-above-the-track-floor.md).
constexpr int kSharedTracksPerMinTrack = 2;

SparseReconstruction TrackForSparse(const std::vector<cv::Mat>& frames, int reference,
                                    const SparseOptions& options) {
  if (frames.size() < 3)
    throw ReconstructionError("a burst needs at least 3 frames, got " +
                              std::to_string(frames.size()));
  CheckFrameTimes(options.frame_times, static_cast<int>(frames.size()));
  // Before the tracking, so that a bad option costs no seconds of work.
  options.Check();
  SparseReconstruction tracked;
  StageTimer timer(&tracked.timings_ms, options.progress);
  GridedFeatureOptions features = options.features;
  features.min_shared_tracks = kSharedTracksPerMinTrack * options.min_tracks;
  tracked.tracks = TrackGridedFeatures(frames, reference, features, &tracked.feature_stats);
  timer.Lap("features");
  if (tracked.tracks.num_tracks() < options.min_tracks)
    throw TooFewTracks(frames[reference], tracked, options);
  return tracked;
}

SparseReconstruction ReconstructTracked(SparseReconstruction tracked, int width, int height,
                                        const SparseOptions& options, SharedWork* beside) {
  const GridedFeatureStats& stats = tracked.feature_stats;
  if (stats.left_out.empty())
    return AdjustTracked(std::move(tracked), width, height, options, beside);
  // The frames kept are no longer consecutive: the rolling shutter's path
  // between neighbours spans the frames left out (io/frame_times.h).
  SparseOptions kept_options = options;
  kept_options.frame_times.clear();
  for (const int i : stats.kept_frames)
    kept_options.frame_times.push_back(CaptureTime(options.frame_times, i));
  return AdjustTracked(std::move(tracked), width, height, kept_options, beside);
}

SparseReconstruction ReconstructSparse(const std::vector<cv::Mat>& frames, int reference,
                                       const SparseOptions& options, SharedWork* beside) {
  return ReconstructTracked(TrackForSparse(frames, reference, options), frames[reference].cols,
                            frames[reference].rows, options, beside);
}

SparseReconstruction ReconstructFromTracks(FeatureTracks tracks, int width, int height,
                                           const SparseOptions& options) {
  options.Check();
  CheckFrameTimes(options.frame_times, tracks.num_frames());
  if (tracks.num_tracks() < options.min_tracks)
    throw ReconstructionError("too few tracks: " + std::to_string(tracks.num_tracks()) +
                              " (need >= " + std::to_string(options.min_tracks) + ")");
  SparseReconstruction tracked;
  tracked.tracks = std::move(tracks);
  return AdjustTracked(std::move(tracked), width, height, options, nullptr);
}

}  // namespace dfsm
