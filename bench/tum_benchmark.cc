// Real frames against real depth: windows of TUM RGB-D fr1/xyz
// (../shared/data/tum_fr1_xyz, a webcam with the published calibration and a
// Kinect's depth) through the whole pipeline, with the known calibration held
// fixed and self-calibrated, scored against the Kinect depth after one global
// scale, beside a constant-depth guess. One JSON line per window and mode,
// then a Markdown table; with --pictures DIR, one picture per window
// (reference, depth, Kinect depth, error; known calibration above,
// self-calibrated below) as DIR/window-FIRST-LAST.jpg.
//   tum_benchmark [--dataset DIR] [--frames N] [--step S] [--start K] [--calibration FILE]
//                 [--rolling-shutter global|estimate|R] [--pictures DIR]
//                 [--semi-global off|P1:P2] [--downscale N] [--without LAYER,...]
//                 [--true-poses R] [--shifts N] [--pinned-depth on|off]
// --without: sparse layers switched off by name (core/sparse/sparse_layers.h).
// --downscale 2 runs the same windows at 320x240 (frames area-averaged, the
// Kinect depth and the calibration scaled to match; TumSequence).
// Where the sequence has groundtruth.txt, each result's JSON line carries
// `pose_error`: the estimated poses against the motion capture's (rotation
// error in degrees, and the translations' residual after one best scale, a
// fraction of the true translations: 0 exact, 1 unrelated, above 1 reversed).
// --true-poses R adds a row "truth" per window: the dense stage alone with
// the published camera, the motion capture's poses, readout R (a fraction of
// the frame interval) and the Kinect's depth range: what the dense stage
// makes of the window when the geometry is right.
// --pinned-depth on: each line also carries "pinned": the sparse stage's
// tracks pinned to the Kinect's depth, the poses adjusted to it under the
// mode's camera, the dense stage over that geometry, and the camera the
// tracks choose at those depths (bench/pinned_depth.h;
// docs/experiments/032-tracks-pinned-to-the-true-depth.md).
// --start K: the first window's first frame. ../shared/data/tum_fr1_rpy holds
// eight windows of 12 frames (one before and one after the 10 that count), so
// its windows are --dataset ../shared/data/tum_fr1_rpy --start 1 --step 12.
// --shifts N: each window also starts 1 .. N-1 frames later, so that a
// figure is not one set of windows' luck. fr1/rpy's 24 windows within its
// 12-frame pieces: --start 0 --step 12 --shifts 3 (windows 0-9, 1-10 and 2-11
// of each piece); their medians are what other windows of the sequence give
// (docs/experiments/022-windows-one-frame-apart.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/pinned_depth.h"
#include "bench/report_options.h"
#include "bench/tum_pictures.h"
#include "bench/tum_sequence.h"
#include "core/dense/dense_depth.h"
#include "core/pipeline/evaluation.h"
#include "core/pipeline/lens_resampling.h"
#include "core/pipeline/pipeline.h"
#include "core/sparse/sparse_layers.h"

namespace dfsm {
namespace {

// --semi-global off (winner-take-all coarse seeds) or P1:P2 (the penalties).
void ParseSemiGlobal(const std::string& text, DenseOptions* dense) {
  if (text == "off") {
    dense->regularize = false;
    return;
  }
  const size_t colon = text.find(':');
  if (colon == std::string::npos)
    throw std::invalid_argument("--semi-global takes off or P1:P2, got " + text);
  try {
    const double small = NonNegativeNumber("--semi-global", text.substr(0, colon));
    const double large = NonNegativeNumber("--semi-global", text.substr(colon + 1));
    if (std::max(small, large) > std::numeric_limits<float>::max())
      throw std::invalid_argument("out of a float's range");
    dense->semi_global.small_step_penalty = static_cast<float>(small);
    dense->semi_global.large_step_penalty = static_cast<float>(large);
  } catch (const std::invalid_argument&) {
    throw std::invalid_argument("--semi-global takes off or P1:P2, got " + text);
  }
  dense->semi_global.Check();
}

// The estimated poses against the true ones (both X_i = R_i X_ref + T_i).
nlohmann::json PoseError(const std::vector<Pose>& estimated, const std::vector<Pose>& truth) {
  if (estimated.size() != truth.size() || truth.empty()) return nullptr;
  double rotation = 0.0, true_rotation = 0.0, true_baseline = 0.0, scale = 0.0;
  for (size_t i = 0; i < truth.size(); ++i) {
    rotation = std::max(rotation, RotationErrorDeg(estimated[i].R, truth[i].R));
    true_rotation =
        std::max(true_rotation, RotationErrorDeg(Eigen::Matrix3d::Identity(), truth[i].R));
    true_baseline = std::max(true_baseline, truth[i].T.norm());
  }
  const double residual = TranslationResidual(estimated, truth, &scale);
  return {{"rotation_deg", rotation},
          {"true_rotation_deg", true_rotation},
          {"true_translation_mm", 1000.0 * true_baseline},
          {"translation_residual", residual},
          {"translation_sign", scale >= 0.0 ? 1 : -1}};
}

// "0.42"; "-" for a negative value (none measured).
std::string TwoDecimals(double value) {
  if (value < 0.0) return "-";
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", value);
  return text;
}

// The Kinect's inverse depths on a coarse grid: the swept range of a dense
// stage given the true poses (metres).
std::vector<double> TrueInverseDepths(const cv::Mat& truth) {
  std::vector<double> inverse_depths;
  for (int y = 0; y < truth.rows; y += 8)
    for (int x = 0; x < truth.cols; x += 8)
      if (truth.at<float>(y, x) > 0.0f) inverse_depths.push_back(1.0 / truth.at<float>(y, x));
  return inverse_depths;
}

// Issue 55's bar for a depth map "clearly better than a constant depth".
constexpr double kClearlyBetter = 0.7;

}  // namespace
}  // namespace dfsm

int main(int argc, char** argv) {
  using namespace dfsm;
  std::string dataset = "../shared/data/tum_fr1_xyz";
  std::string calibration_file = TumFreiburg1CalibrationFile();
  std::string pictures;
  int frames = 10, step = 3, start = 0, downscale = 1, shifts = 1;
  double true_poses_readout = -1.0;  // --true-poses: none
  bool pinned_depth = false;
  RollingShutterOptions rolling_shutter;
  DenseOptions dense;
  std::optional<TumSequence> opened;  // once the options are read
  SparseOptions sparse;               // all but the known calibration
  try {
    for (int i = 1; i < argc; i += 2) {
      const std::string option = argv[i];
      if (i + 1 >= argc) throw std::invalid_argument(option + " needs a value");
      const char* value = argv[i + 1];
      if (option == "--dataset")
        dataset = value;
      else if (option == "--frames")
        frames = WholeNumber("--frames", value, 1);
      else if (option == "--step")
        step = WholeNumber("--step", value, 1);
      else if (option == "--start")
        start = WholeNumber("--start", value, 0);
      else if (option == "--calibration")
        calibration_file = value;
      else if (option == "--pictures")
        pictures = value;
      else if (option == "--rolling-shutter")
        rolling_shutter = ParseRollingShutter(value);
      else if (option == "--semi-global")
        ParseSemiGlobal(value, &dense);
      else if (option == "--downscale")
        downscale = WholeNumber("--downscale", value, 1);
      else if (option == "--without")
        sparse = WithoutLayers(sparse, value);
      else if (option == "--true-poses")
        true_poses_readout = NonNegativeNumber("--true-poses", value);
      else if (option == "--pinned-depth")
        pinned_depth = OnOff("--pinned-depth", value);
      else if (option == "--shifts")
        shifts = WholeNumber("--shifts", value, 1);
      else
        throw std::invalid_argument("unknown option " + option +
                                    " (see the comment at the top of bench/tum_benchmark.cc)");
    }
    opened.emplace(dataset, downscale);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tum_benchmark: %s\n", e.what());
    return 2;
  }
  const TumSequence& sequence = *opened;
  if (sequence.empty()) {
    std::fprintf(stderr, "tum_benchmark: no TUM sequence at %s (rgb.txt, depth.txt)\n",
                 dataset.c_str());
    return 77;
  }
  const ImportedCalibration known = sequence.ReadCalibration(calibration_file);
  std::printf(
      "# calibration %s: f %.1f, k1 %.4f, k2 %.4f (fit %.2f px RMS at %dx%d); frames %dx%d\n",
      calibration_file.c_str(), known.camera.f, known.camera.k1, known.camera.k2,
      known.fit_rms_error_px, TumSequence::kWidth, TumSequence::kHeight, sequence.width(),
      sequence.height());
  // The pipeline's resampling of the frames under the known camera, for the
  // pinned geometry's frames and truth: one camera, one set of maps.
  const std::optional<LensResampling> known_resampling =
      pinned_depth && known.lens ? std::optional(LensResampling(*known.lens, known.camera))
                                 : std::nullopt;
  struct Row {
    int first = 0;
    std::string mode;
    DepthEvaluation score, constant, filled;
    double f = 0.0;
    std::string quality;
    double disagreement = 0.0;   // the depth check's median, without ground truth
    std::string verdict;         // result.json's depth_verdict.quality
    double relief_sigma = -1.0;  // the depth check's: the camera's noise on the relief
    std::string known_fit;       // "fits" | "does not fit" | "" (no calibration checked)
    bool ok = false;
    int frames_left_out = 0;             // by the tracker (result.json's untracked_frames)
    double translation_residual = -1.0;  // against the motion capture; -1: none
  };
  std::vector<Row> rows;
  std::vector<int> firsts;
  for (int base = start; base + frames <= sequence.frames(); base += step)
    for (int first = base; first < base + shifts && first + frames <= sequence.frames(); ++first)
      firsts.push_back(first);
  for (const int first : firsts) {
    const Burst burst = sequence.Window(first, frames);
    const cv::Mat truth = sequence.ReferenceDepth(first, frames);
    const cv::Mat constant(truth.size(), CV_32FC1, cv::Scalar(1.0f));
    const std::vector<Pose> true_poses = sequence.TruePoses(first, frames);
    std::vector<cv::Mat> picture_rows;
    for (const std::string mode : {"known", "self"}) {
      PipelineOptions options;
      options.sparse = sparse;
      options.sparse.rolling_shutter = rolling_shutter;
      options.dense = dense;
      if (mode == "known") {
        KnownCalibration fixed;
        fixed.camera = known.camera;
        fixed.lens = known.lens;
        fixed.mode = KnownCalibrationMode::kFixed;
        fixed.source = calibration_file;
        options.sparse.known = fixed;
      }
      const PipelineOutput output = RunPipeline(burst, options);
      Row row;
      row.first = first;
      row.mode = mode;
      row.constant = EvaluateDepth(constant, truth, cv::Mat());
      nlohmann::json line = {{"first", first}, {"frames", frames}, {"mode", mode}};
      if (output.result.ok && output.dense) {
        row.ok = true;
        row.frames_left_out = static_cast<int>(
            output.result.extra.value("untracked_frames", nlohmann::json::array()).size());
        row.score = EvaluateDepth(output.dense->depth, truth, cv::Mat());
        if (!output.dense->depth_filled.empty())
          row.filled = EvaluateDepth(output.dense->depth_filled, truth, cv::Mat());
        row.f = output.result.calibration.f;
        row.quality = output.result.calibration_detail.value("quality", "");
        const nlohmann::json check = output.result.extra.value("depth_check", nlohmann::json());
        row.disagreement = check.value("median_disagreement", 0.0);
        row.verdict = output.result.extra.value("depth_verdict", nlohmann::json::object())
                          .value("quality", "");
        line["depth_verdict"] = output.result.extra.value("depth_verdict", nlohmann::json());
        row.relief_sigma = check.value("relief_sigma", -1.0);
        const nlohmann::json fit =
            output.result.calibration_detail.value("known_fit", nlohmann::json());
        if (fit.is_object()) row.known_fit = fit.value("fits", true) ? "fits" : "does not fit";
        line["depth_check"] = check;
        line["frame_sharpness"] = output.result.extra.value("frame_sharpness", nlohmann::json());
        line["parallax"] = output.result.extra.value("parallax", nlohmann::json());
        line["untracked_frames"] =
            output.result.extra.value("untracked_frames", nlohmann::json::array());
        line["warnings"] = output.result.warnings;
        line["known_fit"] = fit;
        if (output.sparse) {
          // The sparse stage's poses are those of the frames it kept.
          const std::vector<Pose> kept_truth =
              PosesOfFrames(true_poses, output.sparse->feature_stats.kept_frames);
          line["pose_error"] = PoseError(output.sparse->state.poses, kept_truth);
          if (line["pose_error"].is_object())
            row.translation_residual = line["pose_error"]["translation_residual"];
          if (pinned_depth) {
            // The sparse stage's tracks are on the known camera's grid
            // where its lens was resampled (lens_resampling.h).
            const LensResampling* resampling =
                mode == std::string("known") && known_resampling ? &*known_resampling : nullptr;
            const std::optional<PinnedDepth> pinned = PinDepthToTruth(
                resampling ? resampling->IntoModel(burst) : burst,
                resampling ? resampling->IntoModel(truth, cv::INTER_NEAREST) : truth, cv::Mat(),
                *output.sparse, options.sparse, dense);
            if (pinned) {
              line["pinned"] = ToJson(*pinned);
              line["pinned"]["free_pose_error"] = PoseError(pinned->free.poses, kept_truth);
              line["pinned"]["pinned_pose_error"] = PoseError(pinned->pinned.poses, kept_truth);
            }
          }
        }
        line.update({{"depth", ToJson(row.score)},
                     {"f", row.f},
                     {"rolling_shutter",
                      output.result.calibration_detail.value("rolling_shutter", nlohmann::json())},
                     {"quality", row.quality},
                     {"constant", ToJson(row.constant)},
                     {"filled", ToJson(row.filled)}});
      } else {
        line["error"] = output.result.error;
      }
      std::printf("%s\n", line.dump().c_str());
      std::fflush(stdout);
      rows.push_back(row);
      if (!pictures.empty()) {
        char score[64], baseline[64];
        std::snprintf(score, sizeof(score), "AbsRel %.1f %%, coverage %.0f %%",
                      100.0 * row.score.abs_rel, 100.0 * row.score.coverage);
        std::snprintf(baseline, sizeof(baseline), "a constant: AbsRel %.1f %%",
                      100.0 * row.constant.abs_rel);
        const bool made = output.result.ok && output.dense;
        picture_rows.push_back(TumComparisonRow(
            burst.reference_color, made ? output.dense->depth : cv::Mat(), row.score.scale, truth,
            "frames " + std::to_string(first) + "-" + std::to_string(first + frames - 1) + ", " +
                (mode == std::string("known") ? "published calibration" : "self-calibrated"),
            made ? std::string(score) : "failed: " + output.result.error, baseline));
      }
    }
    if (true_poses_readout >= 0.0 && !true_poses.empty()) {
      DenseOptions given = dense;
      given.readout = true_poses_readout;
      const DenseDepth depth =
          ComputeDenseDepth(burst, known.camera, true_poses, TrueInverseDepths(truth), given);
      Row row;
      row.first = first;
      row.mode = "truth";
      row.ok = true;
      row.f = known.camera.f;
      row.quality = "given";
      row.verdict = "-";
      row.constant = EvaluateDepth(constant, truth, cv::Mat());
      row.score = EvaluateDepth(depth.depth, truth, cv::Mat());
      if (!depth.depth_filled.empty())
        row.filled = EvaluateDepth(depth.depth_filled, truth, cv::Mat());
      nlohmann::json line = {{"first", first},
                             {"frames", frames},
                             {"mode", "truth"},
                             {"readout", true_poses_readout},
                             {"depth", ToJson(row.score)},
                             {"filled", ToJson(row.filled)},
                             {"constant", ToJson(row.constant)}};
      std::printf("%s\n", line.dump().c_str());
      std::fflush(stdout);
      rows.push_back(row);
    }
    if (!pictures.empty()) {
      cv::Mat picture;
      cv::vconcat(picture_rows, picture);
      std::filesystem::create_directories(pictures);
      const std::string file = pictures + "/window-" + std::to_string(first) + "-" +
                               std::to_string(first + frames - 1) + ".jpg";
      cv::imwrite(file, picture, {cv::IMWRITE_JPEG_QUALITY, 80});
    }
  }
  std::printf(
      "\n| window | mode | f (px) | verdict | AbsRel | within 5 %% | within 25 %% | coverage | "
      "filled: AbsRel | filled: within 25 %% | filled: coverage | constant AbsRel | depth check "
      "| relief sigma | known calibration | frames left out | translation residual |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows) {
    if (!r.ok) {
      std::printf("| %d-%d | %s | failed |||||||||| %.1f %% ||||||\n", r.first,
                  r.first + frames - 1, r.mode.c_str(), 100.0 * r.constant.abs_rel);
      continue;
    }
    std::printf(
        "| %d-%d | %s | %.0f | %s | %.1f %% | %.1f %% | %.1f %% | %.1f %% | %.1f %% | %.1f %% | "
        "%.1f %% | %.1f %% | %s (%.1f %%) | %.1f %% | %s | %d | %s |\n",
        r.first, r.first + frames - 1, r.mode.c_str(), r.f, r.quality.c_str(),
        100.0 * r.score.abs_rel, 100.0 * r.score.within_5_percent,
        100.0 * r.score.within_25_percent, 100.0 * r.score.coverage, 100.0 * r.filled.abs_rel,
        100.0 * r.filled.within_25_percent, 100.0 * r.filled.coverage, 100.0 * r.constant.abs_rel,
        r.verdict.c_str(), 100.0 * r.disagreement, 100.0 * r.relief_sigma,
        r.known_fit.empty() ? "-" : r.known_fit.c_str(), r.frames_left_out,
        TwoDecimals(r.translation_residual).c_str());
  }
  // Over the windows with a result: a failed window has no score to count.
  for (const std::string mode : {"known", "self", "truth"}) {
    std::vector<double> abs_rel, filled, filled_within_25, translation_residual;
    int windows = 0, better = 0, clearly_better = 0, worse_unflagged = 0;
    for (const Row& r : rows) {
      if (r.mode != mode) continue;
      ++windows;
      if (r.ok) {
        better += r.score.abs_rel < r.constant.abs_rel;
        clearly_better += r.score.abs_rel < kClearlyBetter * r.constant.abs_rel;
        worse_unflagged += r.score.abs_rel >= r.constant.abs_rel && r.verdict != "unreliable";
        abs_rel.push_back(r.score.abs_rel);
        filled.push_back(r.filled.abs_rel);
        filled_within_25.push_back(r.filled.within_25_percent);
        if (r.translation_residual >= 0.0) translation_residual.push_back(r.translation_residual);
      }
    }
    if (!abs_rel.empty())
      std::printf(
          "median, %s: %zu of %d windows with a result, %d better than a constant (%d under "
          "%.1fx its AbsRel), %d not better and not unreliable; AbsRel %.1f %%; filled: AbsRel "
          "%.1f %%, within 25 %% %.1f %%; translation residual %s\n",
          mode.c_str(), abs_rel.size(), windows, better, clearly_better, kClearlyBetter,
          worse_unflagged, 100.0 * WindowMedian(abs_rel), 100.0 * WindowMedian(filled),
          100.0 * WindowMedian(filled_within_25),
          TwoDecimals(translation_residual.empty() ? -1.0 : WindowMedian(translation_residual))
              .c_str());
  }
  return 0;
}
