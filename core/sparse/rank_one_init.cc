#include "core/sparse/rank_one_init.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/sparse/robust_sigma.h"

namespace dfsm {

void RankOneOptions::Check() const {
  if (max_iterations < 1)
    throw std::invalid_argument("rank-1 max_iterations must be >= 1, got " +
                                std::to_string(max_iterations));
  if (!(outlier_sigmas > 0.0)) throw std::invalid_argument("rank-1 outlier_sigmas must be > 0");
  if (!(min_outlier_px > 0.0)) throw std::invalid_argument("rank-1 min_outlier_px must be > 0");
  if (rejection_rounds < 0)
    throw std::invalid_argument("rank-1 rejection_rounds must be >= 0, got " +
                                std::to_string(rejection_rounds));
}
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

// How a small correction delta of the frame's rotation (R_i <- R_i exp([delta]x))
// moves a de-rotated observation q: the rotational flow field at q.
Eigen::Matrix<double, 2, 3> RotationalFlow(const Eigen::Vector2d& q) {
  Eigen::Matrix<double, 2, 3> B;
  B << q.x() * q.y(), -(1.0 + q.x() * q.x()), q.y(), 1.0 + q.y() * q.y(), -q.x() * q.y(), -q.x();
  return B;
}

struct Factors {
  std::vector<Eigen::Vector3d> C;      // per non-reference frame
  std::vector<Eigen::Vector3d> delta;  // per non-reference frame: rotation correction
  std::vector<double> w;               // per track
};

// Residual of one observation: p - q = w (C - C_z q) + B(q) delta. The rotation
// term absorbs what the rotation-only estimate got wrong: it took part of the
// translation's parallax for rotation, and the leftover rotational flow, as
// large as the parallax itself, would break the rank-1 structure.
Eigen::Vector2d Residual(const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                         const Eigen::Vector3d& C, const Eigen::Vector3d& delta, double w) {
  return (p - q) - w * (C.head<2>() - C.z() * q) - RotationalFlow(q) * delta;
}

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
  factors.delta.assign(frames, Eigen::Vector3d::Zero());
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
      if (use[j])
        cost += Residual(flow.p[j], flow.q[k][j], f.C[k], f.delta[k], f.w[j]).squaredNorm();
  return cost;
}

// Levenberg-Marquardt on the exact model; returns the iterations taken.
// Each inverse depth touches one column of the problem, so it is eliminated by
// a Schur complement and every iteration solves a dense system over the
// frames' 6 unknowns (centre and rotation correction) alone.
int RefineBilinear(const DerotatedFlow& flow, Factors* f, const std::vector<bool>& use,
                   int max_iterations) {
  const int frames = static_cast<int>(f->C.size());
  const int m = static_cast<int>(f->w.size());
  const int unknowns = 6 * frames;
  double cost = Cost(flow, *f, use);
  double lambda = 1e-6;
  int iteration = 0;
  std::vector<Eigen::Matrix<double, 2, 6>> J(frames);
  std::vector<Eigen::Vector2d> g(frames), r(frames);
  // Per track j: h_ww = d^2 cost / d w_j^2, b_w its gradient and column j of
  // H_tw = d^2 cost / d theta d w_j (every frame's six unknowns stacked). The
  // Schur complement's correction H_tw diag(h_ww)^-1 H_tw^T is one
  // symmetric product over all tracks, not a rank-1 update per track.
  std::vector<double> h_ww(m), b_w(m);
  Eigen::MatrixXd H_tw(unknowns, m), scaled(unknowns, m);
  for (; iteration < max_iterations && cost > 1e-30; ++iteration) {
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(unknowns, unknowns);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns);
    Eigen::VectorXd w_gradient = Eigen::VectorXd::Zero(m);  // b_w / h where h > 0
    H_tw.setZero();
    scaled.setZero();
    for (int j = 0; j < m; ++j) {
      h_ww[j] = b_w[j] = 0.0;
      if (!use[j]) continue;
      for (int k = 0; k < frames; ++k) {
        const Eigen::Vector2d& q = flow.q[k][j];
        g[k] = f->C[k].head<2>() - f->C[k].z() * q;  // d residual / d w, negated
        r[k] = Residual(flow.p[j], q, f->C[k], f->delta[k], f->w[j]);
        const Eigen::Matrix<double, 2, 3> B = RotationalFlow(q);
        J[k] << f->w[j], 0.0, -f->w[j] * q.x(), B.row(0), 0.0, f->w[j], -f->w[j] * q.y(), B.row(1);
        h_ww[j] += g[k].squaredNorm();
        b_w[j] += g[k].dot(r[k]);
        H_tw.block<6, 1>(6 * k, j) = J[k].transpose() * g[k];
        S.block<6, 6>(6 * k, 6 * k) += J[k].transpose() * J[k];
        rhs.segment<6>(6 * k) += J[k].transpose() * r[k];
      }
      const double h = h_ww[j] * (1.0 + lambda);
      if (h <= 0.0) continue;
      w_gradient(j) = b_w[j] / h;
      scaled.col(j) = H_tw.col(j) / std::sqrt(h);
    }
    rhs.noalias() -= H_tw * w_gradient;
    S.selfadjointView<Eigen::Lower>().rankUpdate(scaled, -1.0);
    S = S.selfadjointView<Eigen::Lower>();
    // Damping also handles the scale gauge (C, w) -> (sC, w/s), along which S is singular.
    S.diagonal().array() += lambda * S.diagonal().array() + 1e-15;
    const Eigen::VectorXd step = S.ldlt().solve(rhs);
    Factors trial = *f;
    for (int k = 0; k < frames; ++k) {
      trial.C[k] += step.segment<3>(6 * k);
      trial.delta[k] += step.segment<3>(6 * k + 3);
    }
    const Eigen::VectorXd w_step = H_tw.transpose() * step;
    for (int j = 0; j < m; ++j) {
      const double h = h_ww[j] * (1.0 + lambda);
      if (!use[j] || h <= 0.0) continue;
      trial.w[j] += (b_w[j] - w_step(j)) / h;
    }
    NormalizeGauge(&trial, use);
    const double trial_cost = Cost(flow, trial, use);
    if (trial_cost < cost) {
      const double decrease = cost - trial_cost;
      *f = std::move(trial);
      cost = trial_cost;
      lambda = std::max(lambda / 10.0, 1e-12);
      if (decrease <= 1e-10 * cost) {
        ++iteration;
        break;
      }
    } else {
      lambda *= 10.0;
      if (lambda > 1e8) break;
    }
  }
  // Tracks left out of the fit still get their best inverse depth.
  for (int j = 0; j < m; ++j) {
    if (use[j]) continue;
    double num = 0.0, den = 0.0;
    for (int k = 0; k < frames; ++k) {
      const Eigen::Vector2d& q = flow.q[k][j];
      const Eigen::Vector2d gk = f->C[k].head<2>() - f->C[k].z() * q;
      num += gk.dot(flow.p[j] - q - RotationalFlow(q) * f->delta[k]);
      den += gk.squaredNorm();
    }
    f->w[j] = den > 0.0 ? num / den : 0.0;
  }
  return iteration;
}

}  // namespace

RankOneResult RankOneInit(const FeatureTracks& tracks, const CameraModel& camera,
                          const std::vector<Eigen::Matrix3d>& rotations,
                          const RankOneOptions& options) {
  RankOneResult result;
  const int m = tracks.num_tracks();
  if (m < 3 || tracks.num_frames() < 2) return result;
  std::vector<Eigen::Matrix3d> refined = rotations;
  DerotatedFlow flow = Derotate(tracks, camera, refined);
  std::vector<bool> use(m, true);

  Factors factors = InitialFactorization(flow, use);
  NormalizeGauge(&factors, use);
  for (int round = 0; round <= options.rejection_rounds; ++round) {
    // The rotation correction is linearized: fold it into the rotations,
    // de-rotate again and refine until it vanishes.
    for (int relinearization = 0; relinearization < 5; ++relinearization) {
      result.iterations += RefineBilinear(flow, &factors, use, options.max_iterations);
      double largest = 0.0;
      for (size_t k = 0; k < flow.frames.size(); ++k) {
        const Eigen::Vector3d& delta = factors.delta[k];
        largest = std::max(largest, delta.norm());
        if (delta.norm() > 0.0)
          refined[flow.frames[k]] *= Eigen::AngleAxisd(delta.norm(), delta.normalized()).matrix();
        factors.delta[k].setZero();
      }
      flow = Derotate(tracks, camera, refined);
      if (largest < 1e-9) break;  // radians: 2e-6 px at f = 2000
    }
    // Per-track RMS residual in pixels.
    std::vector<double> rms(m, 0.0);
    for (int j = 0; j < m; ++j) {
      for (size_t k = 0; k < factors.C.size(); ++k)
        rms[j] += Residual(flow.p[j], flow.q[k][j], factors.C[k], factors.delta[k], factors.w[j])
                      .squaredNorm();
      rms[j] = camera.f * std::sqrt(rms[j] / factors.C.size());
    }
    // Sigma from every track: outliers, a minority, barely move the median.
    const double threshold =
        std::max(options.min_outlier_px, options.outlier_sigmas * RobustSigma(rms));
    std::vector<bool> next(m);
    for (int j = 0; j < m; ++j) next[j] = rms[j] <= threshold && factors.w[j] > 0.0;
    if (round == 0) {
      // The first fit saw the outliers too, and least squares spreads their
      // error over every track (through the shared centres and rotation
      // corrections). Refit on the better half before judging anyone.
      std::vector<double> sorted = rms;
      std::nth_element(sorted.begin(), sorted.begin() + m / 2, sorted.end());
      for (int j = 0; j < m; ++j) next[j] = rms[j] <= sorted[m / 2] && factors.w[j] > 0.0;
    }
    double sum = 0.0;
    int count = 0;
    for (int j = 0; j < m; ++j)
      if (next[j]) sum += rms[j] * rms[j], ++count;
    result.rms_residual_px = count > 0 ? std::sqrt(sum / count) : 0.0;
    const bool changed = next != use;
    use = next;
    if (count < 3) return result;
    if (!changed && round > 0) break;
  }

  result.inverse_depths = factors.w;
  result.inliers = use;
  result.poses.resize(tracks.num_frames());
  for (size_t k = 0; k < flow.frames.size(); ++k) {
    const int i = flow.frames[k];
    result.poses[i].R = refined[i];
    result.poses[i].T = -refined[i] * factors.C[k];
  }
  result.ok = true;
  return result;
}

}  // namespace dfsm
