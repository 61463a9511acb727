// How well one burst determines the camera: the marginal covariance of the
// intrinsics (f, k1, k2) after the self-calibrating adjustment, and what it
// means in pixels over the image.
//
// The adjustment's gauge is fixed by the problem itself (the reference pose is
// not a parameter, one inverse depth is held constant), so the information
// matrix J^T J of the remaining parameters is regular whenever the burst
// observes the camera at all. Its inverse's intrinsics block is formed through
// the Schur complement over the inverse depths: every residual sees exactly one
// inverse depth, so that block of J^T J is diagonal and the complement is a
// small dense matrix over intrinsics and poses, accumulated row by row without
// ever holding J densely.
#pragma once

#include <ceres/crs_matrix.h>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "core/camera/camera_model.h"

namespace dfsm {

struct CalibrationUncertainty {
  bool available = false;
  std::string unavailable_reason;  // when !available
  // Covariance of (f [px], k1, k2). Rows/columns of intrinsics the adjustment
  // held fixed are zero.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  // Reprojection noise estimated from the final residuals (robustified): the
  // scale of the covariance.
  double residual_sigma_px = 0.0;
  int degrees_of_freedom = 0;
  // The noise inflation the covariance was computed with (1: none), and the
  // share of it that is the wide-angle factor (BundleAdjustmentOptions::
  // wide_angle_*; 1: none): a wide lens's sigma counts the model's error at
  // its field of view, not only the burst's noise.
  double inflation = 1.0;
  double wide_angle_factor = 1.0;
  // Propagated to the grid of MeanDistortionError: the standard deviation of
  // where the estimated D->U model sends a pixel in the undistorted image, in
  // pixels, mean and largest over the grid (f enters only through the
  // normalized radius, as in the metric).
  double distortion_sigma_px = 0.0;
  double distortion_sigma_max_px = 0.0;
  // The estimated rolling-shutter readout's standard deviation (frame
  // intervals), marginal like the intrinsics'; -1 where the readout was not
  // estimated or the information matrix is singular. Computed with the
  // intrinsics held fixed as well (`available` then stays false).
  double sigma_readout = -1.0;
  // What the camera's uncertainty (intrinsics, poses, readout) does to the
  // relief of the depth: the RMS over the tracks of the standard deviation of
  // their relative inverse depth error after one global scale, the error
  // every tracked point shares with its neighbours (a rotation error shifts
  // all inverse depths by one offset: the small-motion ambiguity between
  // rotation and inverse depth), which no dense matching repairs. Each
  // track's own noise is left out: the dense stage measures its pixels
  // afresh. A fraction (0.05: 5 %); -1 where the information matrix is
  // singular. Available also where the intrinsics were held fixed.
  double relief_sigma = -1.0;

  double sigma_f_px() const;
  double sigma_f_percent(double f) const;
  double sigma_k1() const;
  double sigma_k2() const;
  double correlation(int a, int b) const;  // 0 where either variance is 0
};

// Inputs of MarginalIntrinsicsCovariance, as Ceres' Problem::Evaluate returns
// them: the columns of both jacobians are ordered [intrinsics (tangent size
// `intrinsics_columns`, 0..3), poses ..., inverse depths ...], the first
// `camera_columns` being intrinsics and poses. Rows of `reprojection` are
// residuals in pixels; rows of `prior` are already whitened (unit variance).
struct AdjustmentJacobians {
  ceres::CRSMatrix reprojection;
  std::vector<double> reprojection_residuals;
  ceres::CRSMatrix prior;  // may have no rows
  int camera_columns = 0;
  int intrinsics_columns = 0;
  // The readout's column among the camera columns (after the poses) when the
  // adjustment estimated it; -1 otherwise.
  int readout_column = -1;
  // Which of (f, k1, k2) each intrinsics column is, in order (a subset manifold
  // that holds k2 leaves {0, 1}; one that holds k1 and k2, {0}).
  std::vector<int> intrinsics_indices;
  // Per residual block of `reprojection` (2 rows each, in order): its track,
  // and the derivative of its residual with respect to the track's reference
  // pixel (row-major 2x2). The reference observation enters every residual of
  // its track, so its noise is shared by them: the covariance counts it.
  std::vector<int> block_track;
  std::vector<Eigen::Matrix2d> reference_jacobians;
  // Every track's inverse depth (indexed by track, like block_track), for
  // relief_sigma; empty: not computed.
  std::vector<double> inverse_depths;
  // The tracking noise is taken as this many times what the residuals show
  // (model error: BundleAdjustmentOptions::uncertainty_inflation). It scales
  // the data's share only, not the priors'.
  double noise_inflation = 1.0;
};

// The marginal covariance of the intrinsics. The adjustment is least squares
// with every residual weighted alike, but a track's residuals share the noise
// of its reference pixel, so the covariance is the sandwich
//   A^-1 (S + N + H_p) A^-1,  A = S + H_p,
// with S the Schur complement of J^T J / sigma^2 over the inverse depths, N
// the reference pixels' share (sum over tracks of P P^T, P the reduced
// jacobian times the residuals' derivative by the reference pixel) and H_p the
// whitened priors. sigma, the per-coordinate tracking noise, is estimated from
// the residuals, whose expected square sum counts both noises. Unavailable,
// with the reason, when the information matrix is not positive definite or a
// row sees two inverse depths.
CalibrationUncertainty MarginalIntrinsicsCovariance(const AdjustmentJacobians& jacobians);

// Fills distortion_sigma_px / _max_px of `uncertainty` for `camera`, on the
// pixel grid of MeanDistortionError (every `step` pixels).
void PropagateToDistortion(const CameraModel& camera, CalibrationUncertainty* uncertainty,
                           int step = 8);

// {"sigma_f_px", "sigma_f_percent", "sigma_k1", "sigma_k2", "correlation":
// {"f_k1", "f_k2", "k1_k2"}, "distortion_sigma_px", "distortion_sigma_max_px",
// "residual_sigma_px", "degrees_of_freedom"}, or {"available": false, "reason"}.
nlohmann::json ToJson(const CalibrationUncertainty& uncertainty, double f);

}  // namespace dfsm
