#include "core/pipeline/pipeline.h"

#include <chrono>
#include <cmath>
#include <functional>
#include <optional>

#include "core/dense/dense_frames.h"
#include "core/dense/radial_inverse.h"
#include "core/export/calibration_export.h"
#include "core/export/depth_export.h"
#include "core/export/ply.h"
#include "core/io/depth_tiff.h"
#include "core/io/exif_focal.h"
#include "core/io/file_util.h"
#include "core/io/frame_times.h"
#include "core/io/stage_timer.h"
#include "core/parallel/parallel_for.h"
#include "core/parallel/shared_work.h"
#include "core/pipeline/depth_check.h"
#include "core/pipeline/frame_selection.h"
#include "core/pipeline/frame_sharpness.h"
#include "core/pipeline/lens_resampling.h"
#include "core/pipeline/repeated_frames.h"
#include "core/sparse/parallax.h"

namespace dfsm {
namespace {

// An option out of its range, found before any work (PipelineOptions::Check):
// the caller's mistake, not an internal error.
struct InvalidOptions : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The starts the adjustment decided on (SparseReconstruction::starts); a
// cost of a start that failed is null.
nlohmann::json StartsJson(const std::vector<StartRecord>& starts) {
  nlohmann::json list = nlohmann::json::array();
  for (const StartRecord& start : starts) {
    nlohmann::json entry = {{"kind", StartKindName(start.kind)},
                            {"start_f_px", start.start_f},
                            {"tracks", start.tracks},
                            {"iterations", start.iterations},
                            {"outcome", StartOutcomeName(start.outcome)}};
    if (start.kind == StartKind::kReadout) entry["start_readout"] = start.start_readout;
    entry["cost"] = std::isfinite(start.cost) ? nlohmann::json(start.cost) : nlohmann::json();
    if (!start.error.empty()) entry["error"] = start.error;
    list.push_back(entry);
  }
  return list;
}

std::vector<ColoredPoint> SparsePointCloud(const SparseReconstruction& sparse,
                                           const cv::Mat& reference_color) {
  std::vector<ColoredPoint> points;
  const FeatureTracks& tracks = sparse.tracks;
  for (int j = 0; j < tracks.num_tracks(); ++j) {
    if (!sparse.inliers[j]) continue;
    const Eigen::Vector2d pixel = tracks.pixels[tracks.reference].col(j);
    const Eigen::Vector2d x = sparse.state.camera.PixelToUndistorted(pixel);
    ColoredPoint point;
    point.position =
        (Eigen::Vector3d(x.x(), x.y(), 1.0) / sparse.state.inverse_depths[j]).cast<float>();
    const cv::Point at(cvRound(pixel.x()), cvRound(pixel.y()));
    if (reference_color.channels() == 3) {
      const cv::Vec3b bgr = reference_color.at<cv::Vec3b>(at);
      point.r = bgr[2], point.g = bgr[1], point.b = bgr[0];
    } else {
      point.r = point.g = point.b = reference_color.at<uchar>(at);
    }
    points.push_back(point);
  }
  return points;
}

// The burst without its repeated frames, and where each of the caller's
// frames went.
struct DistinctFrames {
  DistinctFrames(const Burst& all, const std::vector<int>& repeats) {
    std::vector<int> stage_of(all.size(), -1), distinct;
    for (int i = 0; i < all.size(); ++i) {
      if (repeats[i] >= 0) {
        left_out.push_back({{"frame", i}, {"repeats", repeats[i]}});
        continue;
      }
      stage_of[i] = static_cast<int>(distinct.size());
      distinct.push_back(i);
    }
    burst = SelectFrames(all, distinct);
    for (int i = 0; i < all.size(); ++i)
      stage_index.push_back(repeats[i] >= 0 ? stage_of[repeats[i]] : stage_of[i]);
    times = CaptureTimes(burst.manifest);
    // A manifest that says nothing of time: the frames' places in the burst.
    if (times.empty() && !left_out.empty())
      for (int i = 0; i < all.size(); ++i)
        if (repeats[i] < 0) times.push_back(static_cast<double>(i));
  }

  Burst burst;  // what the stages see
  // Per caller's frame: its (or its original's) index in `burst`.
  std::vector<int> stage_index;
  std::vector<double> times;                          // `burst`'s capture times (io/frame_times.h)
  nlohmann::json left_out = nlohmann::json::array();  // {"frame", "repeats"} per repeat
};

// The sparse stage's pose of each of `distinct.burst`'s frames: a frame the
// tracker left out takes the one at its capture time between the kept ones
// (frame_selection.h), whose times the sparse state holds.
std::vector<Pose> DistinctFramePoses(const SparseReconstruction& sparse,
                                     const DistinctFrames& distinct) {
  const std::vector<int>& kept = sparse.feature_stats.kept_frames;
  if (kept.empty() || sparse.feature_stats.left_out.empty()) return sparse.state.poses;
  const std::vector<double>& kept_times = sparse.state.frame_times;
  std::vector<Pose> poses;
  for (int i = 0, k = 0; i < distinct.burst.size(); ++i) {
    if (k < static_cast<int>(kept.size()) && kept[k] == i)
      poses.push_back(sparse.state.poses[k++]);
    else
      poses.push_back(PoseAtTime(kept_times, sparse.state.poses, CaptureTime(distinct.times, i)));
  }
  return poses;
}

// Each caller's frame's sharpness against the burst's sharpest
// (frame_sharpness.h), on the reference's brightness.
void RecordFrameSharpness(const Burst& compensated, const DistinctFrames& distinct,
                          Result* result) {
  const std::vector<double> sharpness = RelativeSharpness(compensated.gray);
  nlohmann::json list = nlohmann::json::array();
  for (const int stage : distinct.stage_index) list.push_back(sharpness[stage]);
  result->extra["frame_sharpness"] = list;
}

// The frames the tracker left out (GridedFeatureOptions::max_frame_track_loss),
// by the caller's index (with the frames that repeat them), each warned of.
void RecordUntrackedFrames(const SparseReconstruction& tracked, const DistinctFrames& distinct,
                           Result* result) {
  const GridedFeatureStats& stats = tracked.feature_stats;
  if (stats.left_out.empty()) return;
  nlohmann::json frames = nlohmann::json::array();
  std::string listed;
  for (const GridedFeatureStats::LeftOut& left : stats.left_out)
    for (size_t i = 0; i < distinct.stage_index.size(); ++i) {
      if (distinct.stage_index[i] != left.frame) continue;
      frames.push_back({{"frame", i},
                        {"tracks_without", left.tracks_without},
                        {"tracks_with", left.tracks_with},
                        {"pose", "interpolated"}});
      listed += (listed.empty() ? "" : ", ") + std::to_string(i) + " (tracks " +
                std::to_string(left.tracks_without) + " -> " + std::to_string(left.tracks_with) +
                ")";
    }
  result->extra["untracked_frames"] = frames;
  result->warnings.push_back(
      std::to_string(frames.size()) + " frame" + (frames.size() > 1 ? "s" : "") +
      " left out: the tracker lost most tracks there (blur or a jolt); keeping each would have "
      "cut the tracks every other frame shares, frame " +
      listed + "; the pose of a frame left out is interpolated in time, and its image is not used");
}

// A per-stage-frame list as the caller's frames see it (a repeat shows its
// original's value).
nlohmann::json PerCallerFrame(const std::vector<int>& values, const std::vector<int>& stage_index) {
  nlohmann::json list = nlohmann::json::array();
  for (const int stage : stage_index)
    list.push_back(stage >= 0 && stage < static_cast<int>(values.size()) ? values[stage] : -1);
  return list;
}

// `options` whose stages tell `progress` of their laps.
PipelineOptions ReportingTo(PipelineOptions options, const ProgressCallback& progress) {
  options.sparse.progress = progress;
  options.sparse.features.progress = progress;
  options.dense.progress = progress;
  return options;
}

// Whether the dense stage can invert `camera`'s lens (why not, if not).
bool UsableByDenseStage(const CameraModel& camera, std::string* why) {
  try {
    RadialInverse inverse(camera);
    return true;
  } catch (const std::invalid_argument& e) {
    *why = std::string("cannot be inverted for the dense stage (") + e.what() + ")";
    return false;
  }
}

// The sparse stage's options for this burst: where the dense stage runs, a
// camera it cannot invert is refused (SparseOptions::camera_usable), and
// without a known calibration the burst's EXIF focal length is a prior on f.
SparseOptions SparseOptionsForBurst(const Burst& burst, const PipelineOptions& options) {
  SparseOptions sparse_options = options.sparse;
  if (options.run_dense && !sparse_options.camera_usable)
    sparse_options.camera_usable = UsableByDenseStage;
  if (!sparse_options.known && burst.exif_focal_35mm && options.exif_focal_sigma_percent > 0.0) {
    KnownCalibration exif;
    exif.camera = CameraModel::Initial(burst.width(), burst.height());
    exif.camera.f = FocalPixelsFrom35mm(*burst.exif_focal_35mm, burst.width(), burst.height());
    exif.mode = KnownCalibrationMode::kPrior;
    exif.f_sigma_percent = options.exif_focal_sigma_percent;
    exif.distortion_sigma_px = 0.0;  // EXIF says nothing of the distortion
    exif.also_self_calibrate = true;
    exif.check_fit = false;  // a guess the burst may move: its own estimate says it
    exif.source = "exif: " + std::to_string(static_cast<int>(*burst.exif_focal_35mm)) +
                  " mm (35 mm equivalent)";
    sparse_options.known = exif;
  }
  return sparse_options;
}

// Too few distinct frames is the burst's failure, named; the frames left out
// as repeats are listed and warned of in result.json.
void RecordRepeatedFrames(const DistinctFrames& distinct, Result* result) {
  if (distinct.burst.size() < 3)
    throw ReconstructionError("only " + std::to_string(distinct.burst.size()) +
                              " distinct frames: the others repeat them (a still or stalled "
                              "camera); a burst needs at least 3");
  if (!distinct.left_out.empty()) {
    result->extra["repeated_frames"] = distinct.left_out;
    result->warnings.push_back(
        std::to_string(distinct.left_out.size()) + " frame" +
        (distinct.left_out.size() > 1 ? "s repeat" : " repeats") +
        " the frame before (a clip's frame-rate conversion or a stalled driver): left out, "
        "with the pose of the frame repeated");
  }
}

// Both stages see the frames on the reference's brightness; the Mats of
// frames left as they are stay shared with the caller's burst. `compensated`
// starts as the distinct frames; each caller's frame reports its gain.
void CompensateBurstExposure(const Burst& burst, const DistinctFrames& distinct,
                             const PipelineOptions& options, Burst* compensated,
                             SparseOptions* sparse_options, Result* result) {
  const std::vector<FrameCompensation> photometric =
      CompensateExposure(&compensated->gray, compensated->reference(), options.photometric);
  nlohmann::json gains = nlohmann::json::array();
  for (int i = 0; i < burst.size(); ++i) {
    const FrameCompensation& c = photometric[distinct.stage_index[i]];
    gains.push_back({{"gain", c.gain}, {"applied", c.applied}});
  }
  result->extra["photometric_compensation"] = gains;
  // A camera that dropped frames, or frames left out as repeats: the
  // rolling shutter's path between neighbours spans the gap
  // (io/frame_times.h).
  sparse_options->frame_times = distinct.times;
}

// The dense stage's frames depend on the frames alone: each is a piece
// the sparse stage takes up on a core its probes leave idle;
// the dense stage makes the rest. A piece's error is the dense stage's
// (SharedWork keeps it until then). The pieces point into `frames_maker`,
// which outlives `frames_work`.
void StartDenseFrames(const Burst& compensated, const DenseOptions& dense,
                      std::optional<DenseFramesMaker>* frames_maker,
                      std::optional<SharedWork>* frames_work) {
  frames_maker->emplace(compensated,
                        DenseFramesSettingsFor(dense, compensated.width(), compensated.height()));
  std::vector<std::function<void()>> pieces;
  for (int i = 0; i < (*frames_maker)->frames(); ++i)
    pieces.push_back([frames_maker, i] { (*frames_maker)->MakeFrame(i); });
  frames_work->emplace(std::move(pieces));
}

// result.json's "calibration": the camera the sparse stage settled on, and
// how far to trust it (uncertainty, quality, source, a known calibration's
// fit, the noise's bias, the rolling shutter).
void RecordCalibrationDetail(const SparseReconstruction& sparse,
                             const SparseOptions& sparse_options, Result* result) {
  result->calibration = sparse.state.camera;
  nlohmann::json& calibration_detail = result->calibration_detail;
  calibration_detail = {{"uncertainty", ToJson(sparse.uncertainty, sparse.state.camera.f)},
                        {"quality", CalibrationQualityName(sparse.verdict.quality)},
                        {"quality_reasons", sparse.verdict.reasons},
                        {"source", CalibrationSourceName(sparse.calibration_used)}};
  if (sparse.rejected_camera) calibration_detail["rejected"] = ToJson(*sparse.rejected_camera);
  if (sparse_options.known) calibration_detail["known"] = sparse_options.known->source;
  if (sparse.known_fit)
    calibration_detail["known_fit"] = {
        {"known_tracks", sparse.known_fit->known_tracks},
        {"known_rms_px", sparse.known_fit->known_rms_px},
        {"free_tracks", sparse.known_fit->free_tracks},
        {"free_rms_px", sparse.known_fit->free_rms_px},
        {"free_camera", ToJson(sparse.known_fit->free_camera)},
        {"free_quality", CalibrationQualityName(sparse.known_fit->free_quality)},
        {"fits", sparse.known_fit->fits}};
  // What the tracks' noise did to the camera the burst calibrated
  // (bootstrap_bias.h): of the self-calibration beside a known prior where
  // there is one, which is what a fusion takes, else of the camera above;
  // the depth keeps the camera above, a fusion takes `debiased`.
  if (const std::optional<IntrinsicsBias>& bias = sparse.OwnCalibrationBias()) {
    nlohmann::json& detail = calibration_detail["noise_bias"];
    detail = {{"of", sparse.self_estimate ? "self_estimate" : "calibration"},
              {"f_px", bias->f},
              {"k1", bias->k1},
              {"k2", bias->k2},
              {"readout", bias->readout},
              {"replica_noise_px", bias->noise_px},
              {"replicas", bias->replicas},
              {"sigma_f_noise_px", bias->sigma_f_noise_px},
              {"usable", bias->usable}};
    if (const std::optional<CameraModel> debiased = sparse.DebiasedCamera();
        debiased && bias->usable)
      detail["debiased"] = ToJson(*debiased);
  }
  calibration_detail["rolling_shutter"] = {
      {"mode", RollingShutterName(sparse_options.rolling_shutter)},
      {"readout", sparse.state.readout},
      {"row_path", sparse.state.angular_velocities.empty() ? "line" : "angular_velocity"}};
  if (sparse.uncertainty.sigma_readout >= 0.0)
    calibration_detail["rolling_shutter"]["sigma_readout"] = sparse.uncertainty.sigma_readout;
}

// What the sparse stage cannot vouch for: its own warnings, frames the
// burst misses, a feature grid finer than the image allows.
void RecordSparseWarnings(const Burst& burst, const SparseReconstruction& sparse,
                          const SparseOptions& sparse_options, Result* result) {
  std::vector<std::string>& warnings = result->warnings;
  warnings.insert(warnings.end(), sparse.warnings.begin(), sparse.warnings.end());
  if (const int missing = MissingFrames(CaptureTimes(burst.manifest)); missing > 0)
    warnings.push_back(
        "the burst misses " + std::to_string(missing) + " frame" + (missing > 1 ? "s" : "") +
        " between its first and last (gaps in the manifest's sequence numbers or timestamps); "
        "the motion across each gap is taken at the capture times");
  const int requested_cell = sparse_options.features.cell_px;
  const int least_cell = MinGridCellSize(burst.width(), burst.height());
  if (requested_cell > 0 && requested_cell < least_cell) {
    warnings.push_back("grid " + std::to_string(requested_cell) + " px raised to " +
                       std::to_string(least_cell) + " px, the least for " +
                       std::to_string(burst.width()) + "x" + std::to_string(burst.height()) +
                       " (at most " + std::to_string(kMaxGridCells) + " cells)");
  }
}

// The sparse stage's poses (one per caller's frame: a repeat takes its
// original's), adjustment, tracks and timings, and its sparse_detail.
void RecordSparseDetail(const Burst& burst, const SparseReconstruction& sparse,
                        const DistinctFrames& distinct, Result* result) {
  const std::vector<Pose> poses = DistinctFramePoses(sparse, distinct);
  for (int i = 0; i < burst.size(); ++i) result->poses.push_back(poses[distinct.stage_index[i]]);
  result->bundle_adjustment = sparse.bundle_adjustment;
  result->bundle_adjustment.runs = sparse.runs;
  result->features =
      static_cast<int>(std::count(sparse.inliers.begin(), sparse.inliers.end(), true));
  result->features_detected = sparse.feature_stats.corners;
  result->timings_ms.insert(result->timings_ms.end(), sparse.timings_ms.begin(),
                            sparse.timings_ms.end());
  result->extra["sparse_detail"] = {
      {"cells", sparse.feature_stats.cells},
      {"tracked", sparse.feature_stats.tracks},
      {"reached_per_frame", PerCallerFrame(sparse.feature_stats.reached, distinct.stage_index)},
      {"inliers", result->features},
      {"rank1_iterations", sparse.rank_one.iterations},
      {"rank1_rms_residual_px", sparse.rank_one.rms_residual_px},
      {"median_track_motion_px", sparse.tracks.MedianMaxDisplacement()},
      {"starts", StartsJson(sparse.starts)},
      {"mirrored_relief",
       {{"cost_ratio", sparse.mirrored_relief_cost_ratio}, {"kept", sparse.mirrored_relief_kept}}}};
  const Parallax& parallax = sparse.parallax;
  result->extra["parallax"] = {{"median_px", parallax.median_px},
                               {"p90_px", parallax.p90_px},
                               {"baseline_over_depth", parallax.baseline_over_depth},
                               {"relative_depth_sigma", parallax.relative_depth_sigma}};
}

// The dense stage over the sparse stage's camera, poses and readout: the
// depth, its timings (the frames made beside the sparse stage apart) and
// its check against the tracks.
void RunDenseStage(const Burst& compensated, const SparseReconstruction& sparse,
                   const DenseOptions& dense, const DepthCheckOptions& depth_check,
                   DenseFramesMaker* frames_maker, SharedWork* frames_work,
                   PipelineOutput* output) {
  Result& result = output->result;
  const auto dense_start = std::chrono::steady_clock::now();
  // The frames made beside the sparse stage were made in the order of
  // the pieces; the rest are made here, in the dense stage's wall time.
  // Where a piece failed the dense stage makes them itself, after
  // checking its inputs, so that bad data gets the error that names it.
  const int frames_beside = frames_work->taken();
  frames_work->Finish();
  std::optional<DenseFrames> dense_frames;
  if (!frames_work->FirstError()) dense_frames = frames_maker->Take();
  const double frames_ms = MillisecondsBetween(dense_start);
  ReportProgress(dense.progress, "frames", 1, 1);
  double frames_beside_ms = 0.0;
  for (int i = 0; dense_frames && i < frames_beside; ++i)
    frames_beside_ms += dense_frames->frame_ms[i];
  DenseOptions dense_options = dense;
  dense_options.readout = sparse.state.readout;
  dense_options.frame_times = sparse.state.frame_times;
  dense_options.angular_velocities = sparse.state.angular_velocities;
  output->dense =
      ComputeDenseDepth(compensated, sparse.state.camera, sparse.state.poses,
                        sparse.InlierInverseDepths(), dense_options, std::move(dense_frames));
  result.timings_ms.emplace_back("dense", MillisecondsBetween(dense_start));
  DepthSummary depth;
  depth.valid_fraction = output->dense->valid_fraction;
  depth.planes = output->dense->planes;
  depth.min_inverse_depth = output->dense->min_inverse_depth;
  depth.max_inverse_depth = output->dense->max_inverse_depth;
  result.depth = depth;
  nlohmann::json dense_timings = nlohmann::json::object();
  // The frames made here are the first lap of the dense stage's wall
  // time; those made beside the sparse stage (their time summed over
  // the threads) none.
  if (frames_beside > 0) dense_timings["frames_beside_sparse"] = frames_beside_ms;
  dense_timings["frames"] = frames_ms;
  for (const auto& [stage, ms] : output->dense->timings_ms) dense_timings[stage] = ms;
  result.extra["dense_timings_ms"] = dense_timings;
  const DepthCheck check = CheckDepthAgainstTracks(sparse, *output->dense, depth_check);
  result.extra["depth_check"] = ToJson(check);
  result.extra["depth_verdict"] = DepthVerdictJson(check);
  // First of the depth's warnings: the one a client acts on.
  if (check.quality == DepthQuality::kUnreliable) {
    std::string reasons;
    for (const std::string& reason : check.unreliable_reasons)
      reasons += (reasons.empty() ? "" : "; ") + reason;
    result.warnings.push_back("depth unreliable: likely wrong as a whole (" + reasons + ")");
  }
  result.warnings.insert(result.warnings.end(), check.warnings.begin(), check.warnings.end());
}

// The burst the stages see: the captured one, or, where a known camera was
// fitted to another lens (KnownCalibration::lens) of the burst's size, its
// frames resampled onto the camera's grid (lens_resampling.h), recorded in
// the result; the sparse stage refuses a camera of another size itself.
Burst BurstOnCameraGrid(const Burst& captured, const SparseOptions& sparse,
                        std::optional<LensResampling>* resampling, Result* result) {
  if (!sparse.known || !sparse.known->lens || sparse.known->camera.width != captured.width() ||
      sparse.known->camera.height != captured.height())
    return captured;
  const auto start = std::chrono::steady_clock::now();
  resampling->emplace(*sparse.known->lens, sparse.known->camera);
  Burst resampled = (*resampling)->IntoModel(captured);
  result->extra["lens_resampling"] = {{"rms_shift_px", (*resampling)->rms_shift_px()},
                                      {"max_shift_px", (*resampling)->max_shift_px()}};
  result->timings_ms.emplace_back("lens_resampling", MillisecondsBetween(start));
  return resampled;
}

// The dense stage's maps, made on the known camera's grid, on the captured
// one (CONTRACT.md's depth.tiff), after the checks that compare them with the
// tracks on that grid.
void BackToCaptured(const LensResampling& resampling, PipelineOutput* output) {
  DenseDepth& dense = *output->dense;
  dense.depth = resampling.BackToCaptured(dense.depth);
  dense.confidence = resampling.BackToCaptured(dense.confidence);
  dense.depth_filled = resampling.BackToCaptured(dense.depth_filled);
  dense.valid_fraction = DepthFraction(dense.depth);
  if (output->result.depth) output->result.depth->valid_fraction = dense.valid_fraction;
}

}  // namespace

PipelineOptions SparseStageOf(PipelineOptions options) {
  if (options.run_dense && !options.sparse.camera_usable)
    options.sparse.camera_usable = UsableByDenseStage;
  options.run_dense = false;
  return options;
}

SparseReconstruction ReconstructSparseStage(const Burst& burst, PipelineOptions options) {
  options.run_dense = false;
  options.Check();
  PipelineOutput output = RunPipeline(burst, options);
  if (!output.result.ok || !output.sparse) throw ReconstructionError(output.result.error);
  return std::move(*output.sparse);
}

void PipelineOptions::Check() const {
  sparse.Check();
  if (run_dense) {
    dense.Check();
    depth_check.Check();
  }
  if (!(exif_focal_sigma_percent >= 0.0))
    throw std::invalid_argument("exif_focal_sigma_percent must be >= 0 (0: EXIF ignored)");
  photometric.Check();
  repeated_frames.Check();
}

PipelineOutput RunPipeline(const Burst& captured, const PipelineOptions& given,
                           const ProgressCallback& progress) {
  const PipelineOptions options = ReportingTo(given, progress);
  PipelineOutput output;
  Result& result = output.result;
  result.bundle_adjustment.init = InitModeName(options.sparse.init);
  const auto start = std::chrono::steady_clock::now();
  try {
    try {
      options.Check();
    } catch (const std::invalid_argument& e) {
      throw InvalidOptions(std::string("invalid options: ") + e.what());
    }
    std::optional<LensResampling> resampling;
    const Burst burst = BurstOnCameraGrid(captured, options.sparse, &resampling, &result);
    SparseOptions sparse_options = SparseOptionsForBurst(burst, options);
    // The stages see the frames that are not repeats (repeated_frames.h);
    // each frame left out reports what the frame it repeats got.
    const std::vector<int> repeats =
        FindRepeatedFrames(burst.gray, burst.reference(), options.repeated_frames);
    const DistinctFrames distinct(burst, repeats);
    RecordRepeatedFrames(distinct, &result);
    Burst compensated = distinct.burst;
    CompensateBurstExposure(burst, distinct, options, &compensated, &sparse_options, &result);
    RecordFrameSharpness(compensated, distinct, &result);
    SparseReconstruction tracked =
        TrackForSparse(compensated.gray, compensated.reference(), sparse_options);
    RecordUntrackedFrames(tracked, distinct, &result);
    // The later stages see the frames the tracks run through.
    if (!tracked.feature_stats.left_out.empty())
      compensated = SelectFrames(compensated, tracked.feature_stats.kept_frames);
    std::optional<DenseFramesMaker> frames_maker;
    std::optional<SharedWork> frames_work;
    if (options.run_dense)
      StartDenseFrames(compensated, options.dense, &frames_maker, &frames_work);
    output.sparse =
        ReconstructTracked(std::move(tracked), compensated.width(), compensated.height(),
                           sparse_options, frames_work ? &*frames_work : nullptr);
    const SparseReconstruction& sparse = *output.sparse;
    RecordCalibrationDetail(sparse, sparse_options, &result);
    RecordSparseWarnings(burst, sparse, sparse_options, &result);
    RecordSparseDetail(burst, sparse, distinct, &result);
    if (options.run_dense) {
      RunDenseStage(compensated, sparse, options.dense, options.depth_check, &*frames_maker,
                    &*frames_work, &output);
      if (resampling) BackToCaptured(*resampling, &output);
    }
    result.ok = true;
  } catch (const ReconstructionError& e) {
    result.ok = false;
    result.error = e.what();
  } catch (const InvalidOptions& e) {
    result.ok = false;
    result.error = e.what();
  } catch (const std::exception& e) {
    result.ok = false;
    result.error = std::string("internal error: ") + e.what();
  }
  result.timings_ms.emplace_back("total", MillisecondsBetween(start));
  result.extra["input"] = {{"frames", captured.size()},
                           {"width", captured.width()},
                           {"height", captured.height()},
                           {"reference", captured.reference()},
                           {"frame_indices", captured.frame_indices()}};
  return output;
}

void WritePipelineOutputs(const std::filesystem::path& out_dir, const Burst& burst,
                          PipelineOutput* output) {
  std::filesystem::create_directories(out_dir);
  if (output->result.ok) {
    const auto start = std::chrono::steady_clock::now();
    const SparseReconstruction& sparse = *output->sparse;
    // The files are written without an fsync each and flushed together
    // below, before result.json: ten fsyncs cost ~50 ms on our disks.
    nlohmann::json& extra = output->result.extra;
    // Every pixel: the holes of depth.tiff filled from their measured
    // surroundings (core/dense/depth_completion.h); confidence.png tells
    // measured from filled. Null when the dense stage made none.
    const DenseDepth* filled =
        output->dense && !output->dense->depth_filled.empty() ? &*output->dense : nullptr;
    std::optional<DepthOutputWriter> depth_writer;
    nlohmann::json calibration_files;
    std::vector<std::function<void()>> writers;
    if (output->dense) {
      DepthExportOptions options;
      options.flush = Flush::kBatched;
      depth_writer.emplace(out_dir, output->dense->depth, output->dense->confidence,
                           burst.reference_color, sparse.state.camera, options);
      writers = depth_writer->Tasks();
    }
    // One parallel region for every file, the slowest first: at 1080p a
    // region of its own for the depth files waited ~30 ms on preview.png
    // before these two began.
    writers.push_back([&] {
      if (filled)
        WriteDepthTiff(out_dir / "depth_filled.tiff", filled->depth_filled, Flush::kBatched);
    });
    writers.push_back([&] {
      WritePly(out_dir / "sparse_points.ply", SparsePointCloud(sparse, burst.reference_color),
               Flush::kBatched);
      calibration_files = WriteCalibrationFiles(out_dir, sparse.state.camera, Flush::kBatched);
    });
    RunInParallel(writers);
    // Recorded after the writers: they run in parallel and `extra` is not
    // safe to modify from two of them.
    if (depth_writer) extra["depth_outputs"] = depth_writer->Summary();
    extra["calibration_files"] = calibration_files;
    if (filled)
      extra["depth_filled"] = {
          {"file", "depth_filled.tiff"},
          {"measured_fraction", filled->valid_fraction},
          // depth.tiff's pixels: confidence.png >= this x 255 (the rest are filled).
          {"measured_min_confidence", filled->min_confidence},
          {"valid_fraction", DepthFraction(filled->depth_filled)}};
    SyncFileSystem(out_dir);
    extra["write_ms"] = MillisecondsBetween(start);
  }
  // result.json goes last: its presence marks a complete result directory.
  WriteResultJson(out_dir, output->result);
}

}  // namespace dfsm
