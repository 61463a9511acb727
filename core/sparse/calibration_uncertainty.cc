#include "core/sparse/calibration_uncertainty.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <vector>

namespace dfsm {

double CalibrationUncertainty::sigma_f_px() const { return std::sqrt(covariance(0, 0)); }
double CalibrationUncertainty::sigma_f_percent(double f) const {
  return f > 0.0 ? 100.0 * sigma_f_px() / f : 0.0;
}
double CalibrationUncertainty::sigma_k1() const { return std::sqrt(covariance(1, 1)); }
double CalibrationUncertainty::sigma_k2() const { return std::sqrt(covariance(2, 2)); }
double CalibrationUncertainty::correlation(int a, int b) const {
  const double scale = std::sqrt(covariance(a, a) * covariance(b, b));
  return scale > 0.0 ? covariance(a, b) / scale : 0.0;
}

namespace {

// Records why the covariance is not there, unless the intrinsics were held
// fixed, which is the reason that stands.
void Unavailable(CalibrationUncertainty* result, const char* reason) {
  if (result->unavailable_reason.empty()) result->unavailable_reason = reason;
}

// The camera's information with the inverse depths eliminated, unscaled: S =
// sum J_c^T J_c - v v^T / h (v = J_c^T J_w, h = J_w^T J_w), and the
// reference noise term N = sum P P^T, P = Q - v q^T / h (Q = J_c^T B, q =
// J_w^T B, B = d residual / d reference pixel), v, h, Q and q summed per
// track.
struct ReducedSystem {
  Eigen::MatrixXd S;
  Eigen::MatrixXd N;
  // Sum of |B|^2 over the rows: the reference pixels' share of the
  // residuals' expected square.
  double reference_share = 0.0;
  // Per track, m = v / (h w): the relative inverse depth error is -m^T dc
  // for a camera error dc (the track's own least squares given the camera).
  std::vector<Eigen::VectorXd> relief_rows;
};

// The sums of the track whose rows are being accumulated.
struct CurrentTrack {
  Eigen::VectorXd v;
  Eigen::MatrixXd Q;
  Eigen::RowVector2d q;
  double h = 0.0;
  int track = -1;
  // The inverse depth its rows have seen (-1: none yet); without track ids
  // a track is the run of rows of one inverse depth.
  int depth_seen = -1;
};

// Eliminates the current track's inverse depth from S, records its relief row
// and its share of N, and empties its sums for the next track.
void CloseTrack(const AdjustmentJacobians& jacobians, bool with_reference, bool with_relief,
                CurrentTrack* current, ReducedSystem* reduced) {
  const int c = jacobians.camera_columns;
  const int track = current->track;
  Eigen::VectorXd& v = current->v;
  Eigen::MatrixXd& Q = current->Q;
  Eigen::RowVector2d& q = current->q;
  double& h = current->h;
  if (h > 0.0) reduced->S.noalias() -= v * v.transpose() / h;
  if (with_relief && track >= 0 && track < static_cast<int>(jacobians.inverse_depths.size()) &&
      jacobians.inverse_depths[track] > 0.0)
    reduced->relief_rows.push_back(h > 0.0
                                       ? Eigen::VectorXd(v / (h * jacobians.inverse_depths[track]))
                                       : Eigen::VectorXd::Zero(c));
  if (with_reference) {
    const Eigen::MatrixXd P = h > 0.0 ? Eigen::MatrixXd(Q - v * q / h) : Q;
    reduced->N.noalias() += P * P.transpose();
  }
  v.setZero();
  Q.setZero();
  q.setZero();
  h = 0.0;
  current->depth_seen = -1;
}

// Row `row` of J, split into its entries in the c camera columns and its
// inverse depth's (`depth`: its index, -1 where the row has none). Returns
// false where the row depends on two inverse depths.
bool SplitRow(const ceres::CRSMatrix& J, int row, int c, std::vector<int>* camera_index,
              std::vector<double>* camera_value, int* depth, double* depth_value) {
  camera_index->clear();
  camera_value->clear();
  *depth = -1;
  *depth_value = 0.0;
  for (int k = J.rows[row]; k < J.rows[row + 1]; ++k) {
    const int col = J.cols[k];
    if (col < c) {
      camera_index->push_back(col);
      camera_value->push_back(J.values[k]);
    } else if (*depth < 0 || *depth == col - c) {
      *depth = col - c;
      *depth_value += J.values[k];
    } else {
      return false;
    }
  }
  return true;
}

// Accumulates the reduced system row by row, closing each track where its
// rows end (its residual blocks are consecutive), so that J is never held
// densely. Returns false where a residual depends on two inverse depths.
bool AccumulateReducedSystem(const AdjustmentJacobians& jacobians, ReducedSystem* reduced) {
  const ceres::CRSMatrix& J = jacobians.reprojection;
  const int c = jacobians.camera_columns;
  const bool with_reference =
      jacobians.block_track.size() * 2 == static_cast<size_t>(J.num_rows) &&
      jacobians.reference_jacobians.size() * 2 == static_cast<size_t>(J.num_rows);
  const bool with_relief = with_reference && !jacobians.inverse_depths.empty() && c > 0;
  reduced->S = Eigen::MatrixXd::Zero(c, c);
  reduced->N = Eigen::MatrixXd::Zero(c, c);
  Eigen::MatrixXd& S = reduced->S;
  CurrentTrack current;
  current.v = Eigen::VectorXd::Zero(c);
  current.Q = Eigen::MatrixXd::Zero(c, 2);
  current.q = Eigen::RowVector2d::Zero();
  std::vector<int> camera_index;
  std::vector<double> camera_value;
  for (int row = 0; row < J.num_rows; ++row) {
    const int block = row / 2;
    if (with_reference && jacobians.block_track[block] != current.track) {
      CloseTrack(jacobians, with_reference, with_relief, &current, reduced);
      current.track = jacobians.block_track[block];
    }
    int depth = -1;
    double depth_value = 0.0;
    if (!SplitRow(J, row, c, &camera_index, &camera_value, &depth, &depth_value)) return false;
    if (depth >= 0) {
      // Without track ids, rows of one inverse depth are grouped by it.
      if (!with_reference && depth != current.depth_seen && current.depth_seen >= 0)
        CloseTrack(jacobians, with_reference, with_relief, &current, reduced);
      current.depth_seen = depth;
    }
    Eigen::RowVector2d b = Eigen::RowVector2d::Zero();
    if (with_reference) b = jacobians.reference_jacobians[block].row(row % 2);
    for (size_t a = 0; a < camera_index.size(); ++a) {
      for (size_t e = 0; e < camera_index.size(); ++e)
        S(camera_index[a], camera_index[e]) += camera_value[a] * camera_value[e];
      current.v[camera_index[a]] += camera_value[a] * depth_value;
      current.Q.row(camera_index[a]) += camera_value[a] * b;
    }
    current.h += depth_value * depth_value;
    current.q += depth_value * b;
    if (with_reference) reduced->reference_share += b.squaredNorm();
  }
  CloseTrack(jacobians, with_reference, with_relief, &current, reduced);
  return true;
}

// The tracking noise's variance per coordinate, from the residuals: E[sum
// r^2] ~ sigma^2 (rows - columns) (1 + share per row), as the reference
// pixel's noise reaches each residual through B.
double TrackingVariance(const AdjustmentJacobians& jacobians, double reference_share,
                        int degrees_of_freedom) {
  double sum_sq = 0.0;
  for (const double r : jacobians.reprojection_residuals) sum_sq += r * r;
  const double rows = jacobians.reprojection.num_rows;
  return sum_sq / (degrees_of_freedom * (1.0 + reference_share / rows));
}

// Whitens S into A = S / s^2 + H_p and returns the score's covariance (S +
// N) / s^2 + H_p, with s the tracking noise inflated for model error; the
// priors are already whitened.
Eigen::MatrixXd WhitenWithPriors(const AdjustmentJacobians& jacobians, double variance,
                                 const Eigen::MatrixXd& N, Eigen::MatrixXd* S) {
  const int c = jacobians.camera_columns;
  const double inflated = variance * jacobians.noise_inflation * jacobians.noise_inflation;
  *S /= inflated;
  Eigen::MatrixXd score = *S + N / inflated;
  const ceres::CRSMatrix& P = jacobians.prior;
  for (int row = 0; row < P.num_rows; ++row)
    for (int a = P.rows[row]; a < P.rows[row + 1]; ++a)
      for (int b = P.rows[row]; b < P.rows[row + 1]; ++b)
        if (P.cols[a] < c && P.cols[b] < c) {
          (*S)(P.cols[a], P.cols[b]) += P.values[a] * P.values[b];
          score(P.cols[a], P.cols[b]) += P.values[a] * P.values[b];
        }
  return score;
}

// `matrix` in the equilibrated variables, each divided by its `scale`.
Eigen::MatrixXd Equilibrated(const Eigen::MatrixXd& matrix, const Eigen::VectorXd& scale) {
  return scale.cwiseInverse().asDiagonal() * matrix * scale.cwiseInverse().asDiagonal();
}

// The relief: rows m_j centred (the global scale is free), through the
// whole camera covariance A^-1 score A^-1 (equilibrated: m scaled alike);
// the RMS over the tracks.
double ReliefSigma(const std::vector<Eigen::VectorXd>& relief_rows, int c,
                   const Eigen::VectorXd& scale, const Eigen::LDLT<Eigen::MatrixXd>& ldlt,
                   const Eigen::MatrixXd& normalized_score) {
  Eigen::MatrixXd M(relief_rows.size(), c);
  for (size_t j = 0; j < relief_rows.size(); ++j) M.row(j) = relief_rows[j].transpose();
  M.rowwise() -= M.colwise().mean();
  M = M * scale.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd X = ldlt.solve(M.transpose());  // A^-1 M^T, c x n
  const double sum = (X.transpose() * normalized_score).cwiseProduct(X.transpose()).sum();
  return std::sqrt(std::max(0.0, sum / static_cast<double>(M.rows())));
}

// A^-1 score A^-1, in the equilibrated variables; only the rows of the
// intrinsics and of the readout, scaled back into `result`.
void SetMarginalCovariance(const AdjustmentJacobians& jacobians, const Eigen::VectorXd& scale,
                           const Eigen::LDLT<Eigen::MatrixXd>& ldlt,
                           const Eigen::MatrixXd& normalized_score,
                           CalibrationUncertainty* result) {
  const int c = jacobians.camera_columns;
  const int n = jacobians.intrinsics_columns;
  std::vector<int> wanted;
  for (int i = 0; i < n; ++i) wanted.push_back(i);
  if (jacobians.readout_column >= 0) wanted.push_back(jacobians.readout_column);
  const int k = static_cast<int>(wanted.size());
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(c, k);
  for (int i = 0; i < k; ++i) rhs(wanted[i], i) = 1.0;
  const Eigen::MatrixXd columns = ldlt.solve(rhs);  // c x k of A^-1 (normalized)
  const Eigen::MatrixXd block = columns.transpose() * normalized_score * columns;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      result->covariance(jacobians.intrinsics_indices[a], jacobians.intrinsics_indices[b]) =
          block(a, b) / (scale[a] * scale[b]);
  if (jacobians.readout_column >= 0)
    result->sigma_readout = std::sqrt(std::max(0.0, block(n, n))) / scale[jacobians.readout_column];
  result->available = n > 0;
}

}  // namespace

CalibrationUncertainty MarginalIntrinsicsCovariance(const AdjustmentJacobians& jacobians) {
  CalibrationUncertainty result;
  const ceres::CRSMatrix& J = jacobians.reprojection;
  const int c = jacobians.camera_columns;
  if (jacobians.intrinsics_columns == 0)
    result.unavailable_reason = "the intrinsics were held fixed";
  result.degrees_of_freedom = J.num_rows - J.num_cols;
  if (result.degrees_of_freedom <= 0) {
    Unavailable(&result, "fewer residuals than parameters");
    return result;
  }
  ReducedSystem reduced;
  if (!AccumulateReducedSystem(jacobians, &reduced)) {
    Unavailable(&result, "a residual depends on two inverse depths");
    return result;
  }
  const double variance =
      TrackingVariance(jacobians, reduced.reference_share, result.degrees_of_freedom);
  result.residual_sigma_px = std::sqrt(variance);
  if (!(variance > 0.0)) {
    Unavailable(&result, "the residuals are all zero (noise-free tracks)");
    return result;
  }
  result.inflation = jacobians.noise_inflation;
  Eigen::MatrixXd& S = reduced.S;
  const Eigen::MatrixXd score = WhitenWithPriors(jacobians, variance, reduced.N, &S);

  // Equilibrate before factoring: f is in pixels, k1/k2 and rotations are O(1)
  // and O(1e-3), so the raw matrix spans many orders of magnitude.
  Eigen::VectorXd scale = S.diagonal().cwiseSqrt();
  for (int i = 0; i < c; ++i)
    if (!(scale[i] > 0.0)) {
      Unavailable(&result, "a parameter is not observed by any residual");
      return result;
    }
  const Eigen::MatrixXd normalized = Equilibrated(S, scale);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(normalized);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
      ldlt.vectorD().minCoeff() <= 1e-14 * ldlt.vectorD().maxCoeff()) {
    Unavailable(&result,
                "the information matrix is singular: the burst does not observe the camera");
    return result;
  }
  const Eigen::MatrixXd normalized_score = Equilibrated(score, scale);
  if (reduced.relief_rows.size() >= 2)
    result.relief_sigma = ReliefSigma(reduced.relief_rows, c, scale, ldlt, normalized_score);
  if (jacobians.intrinsics_columns == 0 && jacobians.readout_column < 0) return result;
  SetMarginalCovariance(jacobians, scale, ldlt, normalized_score, &result);
  return result;
}

void PropagateToDistortion(const CameraModel& camera, CalibrationUncertainty* uncertainty,
                           int step) {
  if (!uncertainty->available) return;
  const Eigen::Matrix3d& C = uncertainty->covariance;
  double sum = 0.0, largest = 0.0;
  int count = 0;
  for (int v = 0; v < camera.height; v += step) {
    for (int u = 0; u < camera.width; u += step) {
      // The metric compares models through the undistorted image's pixel
      // grid, u_ideal = c + (u - c) F(r^2), r = |u - c| / f, F = 1 + k1 r^2
      // + k2 r^4: only F moves a pixel, by |u - c| dF, with dF/dk1 = r^2,
      // dF/dk2 = r^4, dF/df = -(2 k1 r^2 + 4 k2 r^4) / f.
      const double rho = std::hypot(u - camera.cx, v - camera.cy);
      const double r2 = rho * rho / (camera.f * camera.f);
      const Eigen::Vector3d g(-(2.0 * camera.k1 * r2 + 4.0 * camera.k2 * r2 * r2) / camera.f, r2,
                              r2 * r2);
      const double sigma = rho * std::sqrt(std::max(0.0, g.dot(C * g)));
      sum += sigma;
      largest = std::max(largest, sigma);
      ++count;
    }
  }
  uncertainty->distortion_sigma_px = count > 0 ? sum / count : 0.0;
  uncertainty->distortion_sigma_max_px = largest;
}

nlohmann::json ToJson(const CalibrationUncertainty& uncertainty, double f) {
  if (!uncertainty.available)
    return {{"available", false}, {"reason", uncertainty.unavailable_reason}};
  return {{"available", true},
          {"sigma_f_px", uncertainty.sigma_f_px()},
          {"sigma_f_percent", uncertainty.sigma_f_percent(f)},
          {"sigma_k1", uncertainty.sigma_k1()},
          {"sigma_k2", uncertainty.sigma_k2()},
          {"correlation",
           {{"f_k1", uncertainty.correlation(0, 1)},
            {"f_k2", uncertainty.correlation(0, 2)},
            {"k1_k2", uncertainty.correlation(1, 2)}}},
          {"distortion_sigma_px", uncertainty.distortion_sigma_px},
          {"distortion_sigma_max_px", uncertainty.distortion_sigma_max_px},
          {"residual_sigma_px", uncertainty.residual_sigma_px},
          {"degrees_of_freedom", uncertainty.degrees_of_freedom},
          {"inflation", uncertainty.inflation},
          {"wide_angle_factor", uncertainty.wide_angle_factor}};
}

}  // namespace dfsm
