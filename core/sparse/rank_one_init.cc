#include "core/sparse/rank_one_init.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace dfsm {
namespace {

// De-rotated observations: p[j] for the reference, q[i][j] for frame i (z = 1).
struct DerotatedFlow {
  std::vector<Eigen::Vector2d> p;
  std::vector<std::vector<Eigen::Vector2d>> q;
  std::vector<int> frames;  // the non-reference frames, in order
};

DerotatedFlow Derotate(const FeatureTracks& tracks, const CameraModel& camera,
                       const std::vector<Eigen::Matrix3d>& rotations) {
  DerotatedFlow flow;
  const int m = tracks.num_tracks();
  for (int j = 0; j < m; ++j)
    flow.p.push_back(camera.PixelToUndistorted(tracks.pixels[tracks.reference].col(j)));
  for (int i = 0; i < tracks.num_frames(); ++i) {
    if (i == tracks.reference) continue;
    flow.frames.push_back(i);
    std::vector<Eigen::Vector2d> q(m);
    for (int j = 0; j < m; ++j) {
      const Eigen::Vector2d x = camera.PixelToUndistorted(tracks.pixels[i].col(j));
      const Eigen::Vector3d b = rotations[i].transpose() * Eigen::Vector3d(x.x(), x.y(), 1.0);
      q[j] = b.head<2>() / b.z();
    }
    flow.q.push_back(std::move(q));
  }
  return flow;
}

// Residual of one observation under the exact bilinear model.
Eigen::Vector2d Residual(const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                         const Eigen::Vector3d& C, double w) {
  return (p - q) - w * (C.head<2>() - C.z() * q);
}

struct Factors {
  std::vector<Eigen::Vector3d> C;  // per non-reference frame
  std::vector<double> w;           // per track
};

// Rank-1 SVD of the 2(n-1) x m flow matrix (forward motion ignored).
Factors InitialFactorization(const DerotatedFlow& flow, const std::vector<bool>& use) {
  const int frames = static_cast<int>(flow.frames.size());
  const int m = static_cast<int>(flow.p.size());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(2 * frames, m);
  for (int k = 0; k < frames; ++k)
    for (int j = 0; j < m; ++j)
      if (use[j]) A.block<2, 1>(2 * k, j) = flow.p[j] - flow.q[k][j];
  // The leading left singular vector from the small Gram matrix A A^T.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(A * A.transpose());
  const Eigen::VectorXd u = eigen.eigenvectors().col(2 * frames - 1);
  const Eigen::VectorXd w = A.transpose() * u;
  Factors factors;
  for (int k = 0; k < frames; ++k) factors.C.emplace_back(u(2 * k), u(2 * k + 1), 0.0);
  factors.w.assign(w.data(), w.data() + m);
  return factors;
}

// Fixes the scale and sign gauge: median inverse depth over used tracks = +1.
void NormalizeGauge(Factors* factors, const std::vector<bool>& use) {
  std::vector<double> used;
  for (size_t j = 0; j < factors->w.size(); ++j)
    if (use[j]) used.push_back(factors->w[j]);
  if (used.empty()) return;
  std::nth_element(used.begin(), used.begin() + used.size() / 2, used.end());
  const double median = used[used.size() / 2];
  if (std::abs(median) < 1e-300) return;
  for (double& w : factors->w) w /= median;
  for (Eigen::Vector3d& C : factors->C) C *= median;
}

double Cost(const DerotatedFlow& flow, const Factors& f, const std::vector<bool>& use) {
  double cost = 0.0;
  for (size_t k = 0; k < f.C.size(); ++k)
    for (size_t j = 0; j < f.w.size(); ++j)
      if (use[j]) cost += Residual(flow.p[j], flow.q[k][j], f.C[k], f.w[j]).squaredNorm();
  return cost;
}

// Alternating least squares on the exact model; returns the sweeps taken.
int RefineBilinear(const DerotatedFlow& flow, Factors* f, const std::vector<bool>& use,
                   int max_iterations) {
  const size_t frames = f->C.size(), m = f->w.size();
  double previous = Cost(flow, *f, use);
  int iteration = 0;
  for (; iteration < max_iterations; ++iteration) {
    // Every inverse depth given the centres (also for unused tracks, so that
    // outliers get a value too).
    for (size_t j = 0; j < m; ++j) {
      double num = 0.0, den = 0.0;
      for (size_t k = 0; k < frames; ++k) {
        const Eigen::Vector2d g = f->C[k].head<2>() - f->C[k].z() * flow.q[k][j];
        num += g.dot(flow.p[j] - flow.q[k][j]);
        den += g.squaredNorm();
      }
      f->w[j] = den > 0.0 ? num / den : 0.0;
    }
    // Every centre given the inverse depths: 3x3 normal equations per frame.
    for (size_t k = 0; k < frames; ++k) {
      Eigen::Matrix3d N = Eigen::Matrix3d::Zero();
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      for (size_t j = 0; j < m; ++j) {
        if (!use[j]) continue;
        Eigen::Matrix<double, 2, 3> J;
        J << 1.0, 0.0, -flow.q[k][j].x(), 0.0, 1.0, -flow.q[k][j].y();
        J *= f->w[j];
        N += J.transpose() * J;
        b += J.transpose() * (flow.p[j] - flow.q[k][j]);
      }
      f->C[k] = N.ldlt().solve(b);
    }
    NormalizeGauge(f, use);
    const double cost = Cost(flow, *f, use);
    if (previous - cost <= 1e-14 * previous || cost < 1e-30) {
      ++iteration;
      break;
    }
    previous = cost;
  }
  return iteration;
}

double RobustSigma(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return 1.4826 * values[values.size() / 2];
}

}  // namespace

RankOneResult RankOneInit(const FeatureTracks& tracks, const CameraModel& camera,
                          const std::vector<Eigen::Matrix3d>& rotations,
                          const RankOneOptions& options) {
  RankOneResult result;
  const int m = tracks.num_tracks();
  if (m < 3 || tracks.num_frames() < 2) return result;
  const DerotatedFlow flow = Derotate(tracks, camera, rotations);
  std::vector<bool> use(m, true);

  Factors factors = InitialFactorization(flow, use);
  NormalizeGauge(&factors, use);
  for (int round = 0; round <= options.rejection_rounds; ++round) {
    result.iterations += RefineBilinear(flow, &factors, use, options.max_iterations);
    // Per-track RMS residual in pixels.
    std::vector<double> rms(m, 0.0), used_rms;
    for (int j = 0; j < m; ++j) {
      for (size_t k = 0; k < factors.C.size(); ++k)
        rms[j] += Residual(flow.p[j], flow.q[k][j], factors.C[k], factors.w[j]).squaredNorm();
      rms[j] = camera.f * std::sqrt(rms[j] / factors.C.size());
      if (use[j]) used_rms.push_back(rms[j]);
    }
    const double threshold =
        std::max(options.min_outlier_px, options.outlier_sigmas * RobustSigma(used_rms));
    std::vector<bool> next(m);
    for (int j = 0; j < m; ++j) next[j] = rms[j] <= threshold && factors.w[j] > 0.0;
    double sum = 0.0;
    int count = 0;
    for (int j = 0; j < m; ++j)
      if (next[j]) sum += rms[j] * rms[j], ++count;
    result.rms_residual_px = count > 0 ? std::sqrt(sum / count) : 0.0;
    const bool changed = next != use;
    use = next;
    if (count < 3) return result;
    if (!changed) break;
  }

  result.inverse_depths = factors.w;
  result.inliers = use;
  result.poses.resize(tracks.num_frames());
  for (size_t k = 0; k < flow.frames.size(); ++k) {
    const int i = flow.frames[k];
    result.poses[i].R = rotations[i];
    result.poses[i].T = -rotations[i] * factors.C[k];
  }
  result.ok = true;
  return result;
}

}  // namespace dfsm
