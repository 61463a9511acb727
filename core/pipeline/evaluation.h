// Scores a reconstruction against the ground truth of a synthetic burst, with
// the metrics of Ha et al. and of the project's acceptance targets.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "core/io/ground_truth.h"

namespace dfsm {

struct SparseEvaluation {
  double focal_error_percent = 0.0;
  double distortion_error_px = 0.0;  // MeanDistortionError(estimate, truth)
  double mean_rotation_error_deg = 0.0;
  double max_rotation_error_deg = 0.0;
  double mean_translation_direction_error_deg = 0.0;
};

SparseEvaluation EvaluateSparse(const CameraModel& camera, const std::vector<Pose>& poses,
                                const GroundTruth& truth);

struct DepthEvaluation {
  double scale = 0.0;              // truth ≈ scale * estimate (median ratio)
  double abs_rel = 0.0;            // mean |s d - d*| / d* over valid, textured pixels
  double within_5_percent = 0.0;   // share with max(s d / d*, d* / s d) < 1.05
  double within_25_percent = 0.0;  // the same below 1.25 (the delta < 1.25 of depth benchmarks)
  double coverage = 0.0;           // share of textured pixels with an estimate
  int evaluated_pixels = 0;
  // The relief's share of the error. In small motion a frame's rotation error
  // and an offset of every inverse depth give nearly the same flow, so a map
  // can be right but for an offset b in inverse depth
  // (docs/experiments/123-relief-uncertainty.md). With w = 1 / d the map's
  // inverse depth and w* the
  // truth's, w* = a w + b is fitted over the same pixels by least absolute
  // relative residuals, |(a w + b) / w* - 1| (robust to the few wild pixels
  // beside depth edges). `inverse_depth_offset` is
  // b / (a mean w): the offset as a share of the map's mean inverse depth,
  // scale removed; `abs_rel_after_offset` the mean |d' - d*| / d* of
  // d' = 1 / (a w + b), what is left once that one offset is taken out (1
  // where a w + b <= 0). 0 and abs_rel where the fit is singular.
  double inverse_depth_offset = 0.0;
  double abs_rel_after_offset = 0.0;
};

// Textured pixels: local (7x7) standard deviation of the reference above
// `min_texture_std` grey levels; only they are scored (a flat wall has no depth
// to recover from photo-consistency).
cv::Mat TexturedMask(const cv::Mat& reference_gray, double min_texture_std = 2.0);

// `scale` > 0 scores with that scale instead of the median ratio of these
// pixels: a subset (a moving object's pixels) scored with the scale of the
// whole map, so that its error is not hidden by a scale of its own.
DepthEvaluation EvaluateDepth(const cv::Mat& depth, const cv::Mat& truth_depth,
                              const cv::Mat& textured_mask, double scale = 0.0);

nlohmann::json ToJson(const SparseEvaluation& evaluation);
nlohmann::json ToJson(const DepthEvaluation& evaluation);

}  // namespace dfsm
