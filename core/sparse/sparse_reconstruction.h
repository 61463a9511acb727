// The sparse half of the pipeline: grided features -> rotations -> rank-1
// initialization (or the naive one) -> self-calibrating bundle adjustment.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/camera/opencv_lens.h"
#include "core/camera/rolling_shutter.h"
#include "core/io/burst.h"
#include "core/io/progress.h"
#include "core/io/result.h"
#include "core/parallel/shared_work.h"
#include "core/sparse/bootstrap_bias.h"
#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/calibration_quality.h"
#include "core/sparse/grided_features.h"
#include "core/sparse/init_mode.h"
#include "core/sparse/parallax.h"
#include "core/sparse/rank_one_init.h"
#include "core/sparse/rotation_init.h"

namespace dfsm {

// A burst the method cannot reconstruct; the message names the reason in
// measured terms (e.g. "insufficient parallax: median track motion 0.04 px").
class ReconstructionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// How a known calibration (a file, or the daemon's fused one) enters the
// adjustment: held fixed, or as a prior the burst may move within its widths.
enum class KnownCalibrationMode { kFixed, kPrior };
KnownCalibrationMode ParseKnownCalibrationMode(const std::string& name);  // "fixed" | "prior"
const char* KnownCalibrationModeName(KnownCalibrationMode mode);

// Which camera the later stages got (result.json calibration.source).
enum class CalibrationSource {
  kSelf,           // the burst calibrated itself
  kKnownFixed,     // a known calibration, held
  kKnownPrior,     // a known calibration as a prior the burst moved within
  kFallbackKnown,  // the estimate was unusable: the known calibration instead
  kFallbackK1,     // the estimate was unusable: refitted with k2 = 0
  kFallbackK0,     // the estimate was unusable: refitted with k1 = k2 = 0
};
// "self", "known-fixed", "known-prior", "fallback-known", "fallback-k1",
// "fallback-k0".
const char* CalibrationSourceName(CalibrationSource source);

struct KnownCalibration {
  CameraModel camera;  // principal point included: it replaces the image centre
  // The lens `camera` was fitted to, where the fit misses it: the pipeline
  // then resamples the frames from it onto `camera`'s grid
  // (core/pipeline/lens_resampling.h). Empty: the frames follow `camera`.
  std::optional<OpenCvLens> lens;
  KnownCalibrationMode mode = KnownCalibrationMode::kPrior;
  // Widths of the prior mode: f within this percentage, the distortion's shift
  // of image points within this many pixels.
  double f_sigma_percent = 1.0;
  double distortion_sigma_px = 0.5;  // 0: only f is known
  std::string source;                // where it came from, for result.json ("file:...", "fused")
  // Also estimate the camera from this burst alone (one more adjustment run
  // on the final tracks, without this prior): what a fusion of bursts may add
  // without counting the prior twice (SparseReconstruction::self_estimate).
  bool also_self_calibrate = false;
  // Compare it with the burst calibrated alone on the same tracks
  // (SparseOptions::max_known_fit_ratio; the sparse stage runs twice), whose
  // solution is also a start of the adjustment under it (GivenStart). Off
  // where the camera comes from this camera's own bursts (the daemon's fused
  // calibration) or is a loose guess (EXIF's focal length); there the burst's
  // own solution is a start only where the adjustment under it keeps too few
  // tracks (SparseOptions::min_known_inlier_share).
  bool check_fit = true;
};

struct SparseOptions {
  GridedFeatureOptions features;
  RankOneOptions rank_one;
  BundleAdjustmentOptions bundle_adjustment;
  InitMode init = InitMode::kRankOne;
  uint64_t naive_seed = 0;  // the naive init's random inverse depths
  // With the rank-1 initialization, also probe the naive start (no motion,
  // random inverse depths: the reference code's) beside the focal starts,
  // from the first start's camera (or the known one), and keep it where its
  // truncated reprojection cost over every track is lower by more than 1 %,
  // as a focal start is kept. The rank-1 start can settle in a minimum whose
  // inverse depths share a wrong offset (a flattened relief that still fits
  // its tracks to a few tenths of a pixel): TUM fr1/xyz window 18-27 with
  // the published calibration (docs/experiments/129-naive-probe.md). Like a
  // focal probe, the probe also stands in where the first
  // start fails. False: the rank-1 starts alone.
  bool naive_probe = true;
  int min_tracks = 20;
  double min_parallax_px = 0.15;  // median largest track motion below this: no depth to recover
  // After the adjustment, tracks whose reprojection error exceeds
  // max(this, 4 robust sigmas) are dropped and the adjustment is rerun, for at
  // most `outlier_rounds` rounds. 0.3 px, not ~1.5: measured on rendered
  // bursts (docs/sparse.md, "Outlier tracks on depth edges"), the tracks
  // between 0.3 and 1.5 px are corners on depth edges, and keeping them costs
  // 10-25 % of focal accuracy at VGA.
  double outlier_px = 0.3;
  int outlier_rounds = 3;
  // Then the poses and inverse depths are refined with each track weighed by
  // its own noise, `reweight_rounds` times: a track whose RMS reprojection
  // error e exceeds the median track's m weighs (m / e)^2, at least
  // min_track_weight; the others 1 (AdjustmentAttempt::weights). The tracks'
  // noise is not one sigma: a corner in weak texture, blur or JPEG blocks
  // tracks several times worse than a crisp one, and with equal weights those
  // few set much of the rotations' error, which the dense stage reads as an
  // inverse-depth offset. f, k1, k2 and the readout are held (with them
  // free the calibration lost its corners' evidence and its sigmas their
  // honesty). docs/experiments/125-track-weights.md. 0: off.
  int reweight_rounds = 2;
  double min_track_weight = 0.1;
  // Where the burst calibrates itself, the bias its tracks' noise gives the
  // f, k1, k2 and readout of the solution reported is measured by a
  // parametric bootstrap (bootstrap_bias.h) and reported; a fusion of bursts
  // takes it off (DebiasedCamera). The burst's own depth keeps the camera
  // that fits its tracks best.
  BootstrapBiasOptions bootstrap;
  // Focal lengths the self-calibration starts from, as fractions of
  // max(width, height) (1: the paper's guess, CameraModel::Initial). The
  // first start runs the whole adjustment; each later one is probed beside it
  // (its rotations, rank-1 initialization and first adjustment, capped, on
  // a share of its tracks, kProbeTracks; adjustment_starts.cc) and replaces the
  // solution so far where its truncated reprojection cost over every track
  // (each track's squared RMS error at its best depth under the start's
  // geometry, capped at outlier_px^2) is lower by more than 1 %, then takes
  // in the tracks it left out and finishes with the whole budget. f shows only
  // in second-order terms of small motion, and a wide lens (0.55-0.8: 64-85
  // deg, phones' and webcams' main cameras) started at 1 can stop in another
  // minimum, f tens of percent long (docs/experiments/109-focal-starts.md). A known
  // calibration starts from its own camera only (so does the naive probe,
  // naive_probe, and options.init kNaive starts once).
  std::vector<double> focal_starts = {1.0, 0.6};
  // Where the readout is estimated and the first adjustment measured one, the
  // adjustment restarts from it and from other readouts, each from a rank-1
  // initialization rectified with it (adjustment_starts.cc, kReadoutStarts):
  // a readout and a tilt of the scene trade against each other, and which
  // minimum the adjustment reaches depends on its start
  // (docs/experiments/114-readout-sigma-tum-18-27.md). False: one adjustment
  // with the whole budget.
  bool readout_restarts = true;
  // Measure SparseReconstruction::lens_relief_shift (one adjustment more)
  // where the burst calibrates its own lens; the depth check reads it.
  bool measure_lens_relief = true;
  // Small motion leaves a near-ambiguity in the depth order: the relief
  // mirrored about its median inverse depth (near made far) with the
  // translation reversed moves the tracks almost as the solution does, the
  // rotation taking up the rest. The adjustment runs once more from that
  // mirror, the intrinsics held, and the mirror's solution replaces the
  // first where it fits the tracks better
  // (SparseReconstruction::mirrored_relief; docs/experiments/007-relief-flip.md).
  // Not again for the refinement with each frame's angular velocity, which
  // starts from a solution checked (docs/experiments/027-one-bias-one-mirror.md).
  bool mirrored_relief = true;
  // Under a rolling shutter, each frame's rows turn at the frame's own
  // angular velocity, tied to its neighbours' rotation step with this sigma
  // in pixels per frame interval (BundleAdjustmentOptions::
  // angular_velocity_sigma_px), where the camera is pinned: a known camera
  // held (KnownCalibrationMode::kFixed) in every adjustment; a burst that
  // calibrates itself once its calibration on the line between frame poses
  // is observed (not degenerate), that solution refined with the velocities
  // and kept unless its calibration then comes out degenerate or unusable.
  // Where f is not observed, the velocities take from it the second-order
  // signal it is found by (docs/experiments/023-angular-velocity-per-frame.md,
  // 026). 0: the line between frame poses throughout.
  double angular_velocity_sigma_px = 2.0;
  // A known calibration; without one the burst calibrates the camera alone.
  std::optional<KnownCalibration> known;
  // A known calibration (with check_fit, held fixed or as a prior) is
  // checked against the burst: the same tracks are also calibrated by the
  // burst alone (the whole adjustment once more, about the sparse stage's
  // time again), and a warning says so when the known camera's reprojection
  // RMS, or the number of tracks the burst's own camera keeps, exceeds the
  // other's by more than this factor (SparseReconstruction::known_fit;
  // docs/experiments/122-known-calibration-fit.md). 0: no check.
  double max_known_fit_ratio = 1.2;
  // A known calibration that is not checked (check_fit off: the daemon's
  // fused calibration, EXIF's focal length) whose adjustment keeps fewer
  // than this share of the tracked tracks: the burst is calibrated alone on
  // the same tracks and the adjustment under the known camera made again,
  // its solution one more start (GivenStart), as a checked one always is.
  // The starts made under a known camera can all end in a minimum that
  // rejects a third of the tracks, with the true camera given (phone
  // 320x240 seed 6: 120 of 199 kept, depth 28 % off, the calibration called
  // reliable; 1080p burst 5031 as a prior of 1 %: 163 of 254, 1563 %), where
  // every other burst of the phone sweeps keeps 0.82-1
  // (docs/experiments/136-unchecked-known.md). Below it
  // the sparse stage costs about three adjustments instead of one; 0: never.
  double min_known_inlier_share = 0.75;
  // The sensor's readout: global, known or estimated (rolling_shutter.h).
  RollingShutterOptions rolling_shutter;
  // The frames' capture times in frame intervals, one per frame, increasing
  // (io/frame_times.h reads them from a burst's manifest: a dropped frame
  // leaves a gap of 2); empty: consecutive frames. The rolling shutter's path
  // between frames reads them (SparseState::frame_times).
  std::vector<double> frame_times;
  CalibrationQualityOptions quality;
  // Whether a later stage can use a camera (the dense stage inverts the radial
  // model); a camera it refuses is replaced as a folding one is. Null: only
  // the fold check. Returns false and says why.
  std::function<bool(const CameraModel&, std::string* why)> camera_usable;
  // Hears each lap of the stage as it ends (core/io/progress.h); the
  // features' own steps go to features.progress.
  ProgressCallback progress;

  // Throws std::invalid_argument naming the option out of its range, its
  // parts' options included (features, rank_one, bundle_adjustment, ...).
  void Check() const;
};

// How a start of the self-calibrating adjustment was made (SparseOptions::
// focal_starts, naive_probe, readout_restarts; GivenStart).
enum class StartKind { kFocal, kNaive, kGiven, kReadout };
const char* StartKindName(StartKind kind);  // "focal", "naive", "given", "readout"
// What became of a start: chosen, beaten by another, or no solution.
enum class StartOutcome { kChosen, kBeaten, kFailed };
const char* StartOutcomeName(StartOutcome outcome);  // "chosen", "beaten", "failed"

// One start the adjustment tried, and the decision on it: the starts are
// compared by their truncated cost over every track (the focal, naive and
// given starts) or by their median track error (the readout restarts, among
// themselves and the solution they restart from).
struct StartRecord {
  StartKind kind = StartKind::kFocal;
  double start_f = 0.0;        // pixels
  double start_readout = 0.0;  // frame intervals (a readout restart's)
  int tracks = 0;              // the tracks its first adjustment adjusted
  int iterations = 0;          // over all its adjustments
  double cost = 0.0;           // what it was compared by (NaN where it failed)
  StartOutcome outcome = StartOutcome::kChosen;
  std::string error;  // kFailed: why
};

struct SparseReconstruction {
  FeatureTracks tracks;
  GridedFeatureStats feature_stats;
  SparseState state;          // camera, poses, inverse depths of every track
  std::vector<bool> inliers;  // tracks used by the final adjustment
  BundleAdjustmentSummary bundle_adjustment;
  // Each run of the adjustment (the first, then one per outlier round, then a
  // fallback refit): its own iterations, not a sum.
  std::vector<BundleAdjustmentRun> runs;
  // How well this burst determines the camera, and the verdict on the
  // calibration it estimated (before any fallback).
  CalibrationUncertainty uncertainty;
  CalibrationVerdict verdict;
  // The burst's own calibration when the adjustment used a known one as a
  // prior and KnownCalibration::also_self_calibrate asked for it.
  struct SelfEstimate {
    CameraModel camera;
    CalibrationUncertainty uncertainty;
    CalibrationVerdict verdict;
    std::optional<IntrinsicsBias> bias;  // as intrinsics_bias, of `camera`
  };
  std::optional<SelfEstimate> self_estimate;
  // The check of a known calibration (SparseOptions::max_known_fit_ratio,
  // KnownCalibration::check_fit): the tracks kept and their reprojection RMS
  // under it and with the burst calibrated alone, and the burst's own camera.
  struct KnownFit {
    int known_tracks = 0;  // inliers under the known camera
    double known_rms_px = 0.0;
    int free_tracks = 0;  // inliers of the burst calibrated alone, from the same tracks
    double free_rms_px = 0.0;
    CameraModel free_camera;
    CalibrationQuality free_quality = CalibrationQuality::kDegenerate;
    // The known camera fits when it keeps as many tracks (within the factor)
    // at an RMS within the factor of the free one's.
    bool Fits(double max_ratio) const {
      return known_rms_px <= max_ratio * free_rms_px && free_tracks <= max_ratio * known_tracks;
    }
    // Fits(SparseOptions::max_known_fit_ratio), decided once by the sparse
    // stage: where it is false, the geometry every later stage builds on is
    // in doubt as a whole (the depth check cannot confirm a map against
    // tracks placed by a camera that does not fit them).
    bool fits = true;
  };
  std::optional<KnownFit> known_fit;
  // How far the relief depends on the lens model: the same tracks adjusted
  // again from the solution with k1 alone (k2 held at 0), and the median
  // over the inlier tracks of |b / (a w_j)|, where w' = a w + b fits the
  // second adjustment's inverse depths to the first's (a common scale is
  // free, an offset is relief). A lens with more distortion than k1 and k2
  // describe (a wide angle's higher terms) lets the rotations take an
  // inverse-depth offset that no residual shows; the relief then moves by
  // tens of percent with the model (docs/experiments/124-lens-relief-shift.md).
  // -1: not measured (intrinsics held or given as a
  // prior with its distortion, or a fallback camera).
  double lens_relief_shift = -1.0;
  // How far the relief depends on the camera: where the burst was also
  // calibrated alone beside a known camera, CameraReliefDisagreement of the
  // solution's inverse depths and those of the known fit's solution (from
  // the burst's own starts) where the check ran, else of self_estimate's
  // (from the solution under the prior). A relief the tracks determine barely moves with
  // the camera (TUM fr1/xyz: at most 5 % with free focal lengths 2 % to 130 %
  // off); where the rotation takes up the translation's work, it moves with
  // any camera error, the known camera's or the lens model's
  // (docs/experiments/016-camera-relief-disagreement.md). -1: not measured.
  double camera_relief_disagreement = -1.0;
  // ImplausibleCamera of state.camera where the burst estimated it (a
  // fallback's refit where one replaced the estimate; not a known camera
  // held): where the estimate is no plausible camera, the tracks' agreement
  // and the relief's sigma are measured in it and vouch for nothing. Empty:
  // plausible, or held.
  std::vector<std::string> implausible_camera;
  // MeasureParallax of the inlier tracks under the final state, noise the
  // adjustment's RMS error: what result.json's parallax reports and what
  // the depth check asks of a burst.
  Parallax parallax;
  // The adjustment from the mirrored relief (SparseOptions::mirrored_relief):
  // its cost over the solution's, both with the intrinsics held (1: it came
  // back to the solution; -1: not run), and whether it replaced the solution.
  double mirrored_relief_cost_ratio = -1.0;
  bool mirrored_relief_kept = false;
  // The camera the adjustment estimated, when a fallback replaced it.
  std::optional<CameraModel> rejected_camera;
  CalibrationSource calibration_used = CalibrationSource::kSelf;
  std::vector<std::string> warnings;
  // The bias of f, k1, k2 and the readout that the tracks' noise gave the
  // self-calibrating adjustment, measured by the bootstrap (SparseOptions::
  // bootstrap); empty where none was measured (a known calibration, a
  // fallback's camera, a camera held under the mirrored relief, or a sigma_f
  // too small for the bias to matter).
  std::optional<IntrinsicsBias> intrinsics_bias;
  RankOneResult rank_one;  // diagnostics of the initialization (rank1 mode)
  // Every start tried, in the order they were decided: the starts, then the
  // chosen one's readout restarts (result.json sparse_detail.starts).
  std::vector<StartRecord> starts;
  std::vector<std::pair<std::string, double>>
      timings_ms;  // features, rotation, rank1, bundle_adjustment

  // Inverse depths of the inlier tracks.
  std::vector<double> InlierInverseDepths() const;
  // The bias measured for the burst's own calibration: the self-calibration
  // beside a known prior where there is one (self_estimate), else the camera
  // of `state` (intrinsics_bias, empty unless calibration_used is kSelf).
  const std::optional<IntrinsicsBias>& OwnCalibrationBias() const {
    return self_estimate ? self_estimate->bias : intrinsics_bias;
  }
  // That calibration less its bias where the bias is usable: what a fusion of
  // bursts should take (its mean keeps a bias that no number of bursts
  // averages out); empty where the burst did not calibrate itself.
  std::optional<CameraModel> DebiasedCamera() const;
  // The camera the burst's tracks chose by themselves, where they chose one:
  // its self-calibration beside a known prior, the camera of `state` where
  // it calibrated itself, or the one it estimated before a fallback dropped
  // lens terms (no known calibration was given then). Empty under a known
  // camera with no self-calibration beside it. Not debiased: the minimum of
  // its own tracks' cost, which a joint calibration measures a burst's
  // disagreement from.
  std::optional<CameraModel> OwnCamera() const;
  // The uncertainty that goes with OwnCamera: its self-calibration's, or the
  // burst's own where it calibrated itself. Null after a fallback (the
  // uncertainty is then the refit's, with fewer lens terms than the own
  // camera) and under a known camera.
  const CalibrationUncertainty* OwnUncertainty() const;
  // Whether the tracks were refitted with fewer lens terms than the
  // adjustment estimated (calibration_used kFallbackK1 or kFallbackK0): the
  // relief is then one the burst's own lens model did not choose.
  bool DroppedLensTerms() const;
};

// The method's step 1 alone (TrackGridedFeatures): the tracks, their
// feature_stats and the "features" lap. Frames the tracker left out
// (feature_stats.left_out) are not in the tracks; every later step sees the
// frames of feature_stats.kept_frames. Throws ReconstructionError where too
// few tracks remain, std::invalid_argument for options out of range.
SparseReconstruction TrackForSparse(const std::vector<cv::Mat>& gray_frames, int reference,
                                    const SparseOptions& options = {});

// Every step after the tracking, on TrackForSparse's result; `options` as
// given to it (frame_times of every frame given: the kept ones are taken).
// `beside` as for ReconstructSparse.
SparseReconstruction ReconstructTracked(SparseReconstruction tracked, int width, int height,
                                        const SparseOptions& options = {},
                                        SharedWork* beside = nullptr);

// Both: TrackForSparse, then ReconstructTracked. The poses are those of
// feature_stats.kept_frames.
// Throws ReconstructionError for bursts that cannot be reconstructed.
// `beside` (may be null): pieces of the caller's work that do not depend on
// this stage, handed in to fill a core the stage leaves idle: the probes'
// (AdjustFromStarts: the later focal starts and the naive probe), where the
// adjustment has more than one start. Pieces it did not take
// (SharedWork::taken), the caller runs.
SparseReconstruction ReconstructSparse(const std::vector<cv::Mat>& gray_frames, int reference,
                                       const SparseOptions& options = {},
                                       SharedWork* beside = nullptr);

// The same from tracks already made (tracked by another tracker, or
// simulated: track_simulator.h) in a width x height image: every step after
// the tracking. Throws as ReconstructSparse does.
SparseReconstruction ReconstructFromTracks(FeatureTracks tracks, int width, int height,
                                           const SparseOptions& options = {});

}  // namespace dfsm
