#include "core/pipeline/evaluation.h"

#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace dfsm {

SparseEvaluation EvaluateSparse(const CameraModel& camera, const std::vector<Pose>& poses,
                                const GroundTruth& truth) {
  SparseEvaluation evaluation;
  evaluation.focal_error_percent = 100.0 * std::abs(camera.f - truth.camera.f) / truth.camera.f;
  evaluation.distortion_error_px = MeanDistortionError(camera, truth.camera);
  int frames = 0;
  for (size_t i = 0; i < poses.size() && i < truth.poses.size(); ++i) {
    if (truth.poses[i].T.norm() == 0.0 && truth.poses[i].R.isIdentity()) continue;  // reference
    const double rotation = RotationErrorDeg(poses[i].R, truth.poses[i].R);
    evaluation.mean_rotation_error_deg += rotation;
    evaluation.max_rotation_error_deg = std::max(evaluation.max_rotation_error_deg, rotation);
    const Eigen::Vector3d a = poses[i].Centre(), b = truth.poses[i].Centre();
    if (a.norm() > 0.0 && b.norm() > 0.0)
      evaluation.mean_translation_direction_error_deg +=
          std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
    ++frames;
  }
  if (frames > 0) {
    evaluation.mean_rotation_error_deg /= frames;
    evaluation.mean_translation_direction_error_deg /= frames;
  }
  return evaluation;
}

cv::Mat TexturedMask(const cv::Mat& reference_gray, double min_texture_std) {
  cv::Mat gray, mean, mean_sq;
  reference_gray.convertTo(gray, CV_32F);
  cv::boxFilter(gray, mean, CV_32F, cv::Size(7, 7));
  cv::boxFilter(gray.mul(gray), mean_sq, CV_32F, cv::Size(7, 7));
  const cv::Mat variance = mean_sq - mean.mul(mean);
  return variance > static_cast<float>(min_texture_std * min_texture_std);
}

namespace {

// DepthEvaluation::inverse_depth_offset and abs_rel_after_offset over the
// scored pixels' (estimate, truth) depths: minimizes sum |(a w + b) / w* - 1|
// (relative, as AbsRel is, and robust: a least-squares fit followed the few
// wild pixels beside depth edges, and on a phone VGA map "after" came out at
// twice the AbsRel) by iteratively reweighted least squares from the median
// scale, b = 0.
void FitInverseDepthOffset(const std::vector<cv::Vec2f>& scored, DepthEvaluation* evaluation) {
  evaluation->inverse_depth_offset = 0.0;
  evaluation->abs_rel_after_offset = evaluation->abs_rel;
  if (scored.size() < 2 || !(evaluation->scale > 0.0)) return;
  constexpr int kRounds = 20;
  constexpr double kMinResidual = 1e-4;  // the L1 weight's floor
  double sum_w = 0.0;
  for (const cv::Vec2f& depths : scored) sum_w += 1.0 / depths[0];
  double a = 1.0 / evaluation->scale, b = 0.0;
  for (int round = 0; round < kRounds; ++round) {
    Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    for (const cv::Vec2f& depths : scored) {
      const double w = 1.0 / depths[0], w_true = 1.0 / depths[1];
      // Residual (a w + b) / w* - 1, linear in a and b.
      const Eigen::Vector2d row(w / w_true, 1.0 / w_true);
      const double weight =
          1.0 / std::max(kMinResidual, std::abs(row.dot(Eigen::Vector2d(a, b)) - 1.0));
      normal += weight * row * row.transpose();
      rhs += weight * row;
    }
    const Eigen::FullPivLU<Eigen::Matrix2d> lu(normal);
    if (!lu.isInvertible()) return;
    const Eigen::Vector2d ab = lu.solve(rhs);
    if (!ab.allFinite()) return;
    a = ab[0];
    b = ab[1];
  }
  if (!(a > 0.0)) return;
  evaluation->inverse_depth_offset = b / (a * sum_w / scored.size());
  double after = 0.0;
  for (const cv::Vec2f& depths : scored) {
    const double w = 1.0 / depths[0], w_true = 1.0 / depths[1];
    const double fitted = a * w + b;
    after += fitted > 0.0 ? std::abs(w_true / fitted - 1.0) : 1.0;
  }
  evaluation->abs_rel_after_offset = after / scored.size();
}

}  // namespace

DepthEvaluation EvaluateDepth(const cv::Mat& depth, const cv::Mat& truth_depth,
                              const cv::Mat& textured_mask, double scale) {
  CV_Assert(depth.type() == CV_32FC1 && truth_depth.type() == CV_32FC1 &&
            depth.size() == truth_depth.size());
  DepthEvaluation evaluation;
  std::vector<float> ratios;
  std::vector<cv::Vec2f> scored;  // (estimate, truth) of each ratio's pixel
  int textured = 0, covered = 0;
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const float truth = truth_depth.at<float>(v, u);
      if (truth <= 0.0f || (!textured_mask.empty() && !textured_mask.at<uchar>(v, u))) continue;
      ++textured;
      const float estimate = depth.at<float>(v, u);
      if (estimate > 0.0f && std::isfinite(estimate)) {
        ++covered;
        ratios.push_back(truth / estimate);
        scored.emplace_back(estimate, truth);
      }
    }
  }
  evaluation.coverage = textured > 0 ? static_cast<double>(covered) / textured : 0.0;
  if (ratios.empty()) return evaluation;
  if (scale > 0.0) {
    evaluation.scale = scale;
  } else {
    std::vector<float> sorted = ratios;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    evaluation.scale = sorted[sorted.size() / 2];
  }
  double abs_rel = 0.0;
  int within = 0, within_25 = 0;
  for (const float ratio : ratios) {
    // ratio = d* / d, so s d / d* = s / ratio.
    const double aligned = evaluation.scale / ratio;
    abs_rel += std::abs(aligned - 1.0);
    if (std::max(aligned, 1.0 / aligned) < 1.05) ++within;
    if (std::max(aligned, 1.0 / aligned) < 1.25) ++within_25;
  }
  evaluation.abs_rel = abs_rel / ratios.size();
  evaluation.within_5_percent = static_cast<double>(within) / ratios.size();
  evaluation.within_25_percent = static_cast<double>(within_25) / ratios.size();
  evaluation.evaluated_pixels = static_cast<int>(ratios.size());
  FitInverseDepthOffset(scored, &evaluation);
  return evaluation;
}

nlohmann::json ToJson(const SparseEvaluation& e) {
  return {{"focal_error_percent", e.focal_error_percent},
          {"distortion_error_px", e.distortion_error_px},
          {"mean_rotation_error_deg", e.mean_rotation_error_deg},
          {"max_rotation_error_deg", e.max_rotation_error_deg},
          {"mean_translation_direction_error_deg", e.mean_translation_direction_error_deg}};
}

nlohmann::json ToJson(const DepthEvaluation& e) {
  return {{"scale", e.scale},
          {"abs_rel", e.abs_rel},
          {"within_5_percent", e.within_5_percent},
          {"within_25_percent", e.within_25_percent},
          {"coverage", e.coverage},
          {"evaluated_pixels", e.evaluated_pixels},
          {"inverse_depth_offset", e.inverse_depth_offset},
          {"abs_rel_after_offset", e.abs_rel_after_offset}};
}

}  // namespace dfsm
