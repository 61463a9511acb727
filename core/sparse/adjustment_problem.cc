#include "core/sparse/adjustment_problem.h"

#include <algorithm>
#include <cmath>
#include <ceres/dynamic_autodiff_cost_function.h>

#include "core/camera/rolling_shutter.h"
#include "core/sparse/intrinsics_prior.h"
#include "core/sparse/rolling_shutter_cost_function.h"
#include "core/sparse/rolling_shutter_reprojection_error.h"
#include "core/sparse/undistorted_reprojection_error.h"

namespace dfsm {

// SCRATCH: quadratic (Lagrange through the neighbours) row-time pose path.
bool ScratchSmooth() { static const bool on = getenv("DFSM_SCRATCH_SMOOTH_RS") != nullptr; return on; }
struct SmoothRs {
  Eigen::Vector2d ref, obs;
  double cx, cy, row_ref, row_obs;
  int n, i, r;
  std::vector<int> block;  // frame -> pose block index, -1 none
  int np;
  template <typename T>
  void Path(T const* const* prm, int k, const T& tau, T* out) const {
    auto P = [&](int frame, int c) -> T {
      return block[frame] < 0 ? T(0.0) : prm[1 + block[frame]][c];
    };
    for (int c = 0; c < 6; ++c) {
      T a, b;
      if (k == 0) { a = P(1, c) - P(0, c); b = T(0.0); }
      else if (k == n - 1) { a = P(k, c) - P(k - 1, c); b = T(0.0); }
      else {
        a = (P(k + 1, c) - P(k - 1, c)) * 0.5;
        b = (P(k + 1, c) - 2.0 * P(k, c) + P(k - 1, c)) * 0.5;
      }
      out[c] = P(k, c) + tau * a + tau * tau * b;
    }
  }
  template <typename T>
  bool operator()(T const* const* prm, T* residuals) const {
    const T* intr = prm[0];
    const T& w = prm[1 + np][0];
    const T& readout = prm[2 + np][0];
    T p[3];
    PixelToUndistorted(intr[0], intr[1], intr[2], cx, cy, ref.x(), ref.y(), &p[0], &p[1]);
    p[2] = T(1.0);
    T pr[6];
    Path(prm, r, readout * row_ref, pr);
    T minus_rotation[3], shifted[3];
    for (int k = 0; k < 3; ++k) {
      minus_rotation[k] = -pr[k];
      shifted[k] = p[k] - w * pr[3 + k];
    }
    T wX[3];
    ceres::AngleAxisRotatePoint(minus_rotation, shifted, wX);
    T pi[6];
    Path(prm, i, readout * row_obs, pi);
    T X[3];
    ceres::AngleAxisRotatePoint(pi, wX, X);
    for (int k = 0; k < 3; ++k) X[k] += w * pi[3 + k];
    UndistortedResidual(intr, cx, cy, obs, X, residuals);
    return true;
  }
};
SmoothRs MakeSmooth(const FeatureTracks& tracks, const CameraModel& camera, int j, int i,
                    const Eigen::Vector2d& reference, std::vector<int>* frames) {
  SmoothRs e;
  e.ref = reference;
  e.obs = tracks.pixels[i].col(j);
  e.cx = camera.cx; e.cy = camera.cy;
  e.row_ref = RowTime(1.0, reference.y(), camera.height);
  e.row_obs = RowTime(1.0, e.obs.y(), camera.height);
  e.n = tracks.num_frames(); e.i = i; e.r = tracks.reference;
  e.block.assign(e.n, -1);
  frames->clear();
  auto need = [&](int k) {
    if (k < 0 || k >= e.n || e.block[k] >= 0) return;
    e.block[k] = static_cast<int>(frames->size());
    frames->push_back(k);
  };
  for (int k : {i - 1, i, i + 1}) need(k);
  if (i == 0) need(1);
  if (i == e.n - 1) need(e.n - 2);
  for (int k : {e.r - 1, e.r + 1}) need(k);
  if (e.r == 0) need(1);
  if (e.r == e.n - 1) need(e.n - 2);
  e.np = static_cast<int>(frames->size());
  return e;
}

// SCRATCH: a rotation velocity per frame (omega, per frame interval).
bool ScratchOmega() { static const bool on = getenv("DFSM_SCRATCH_OMEGA") != nullptr; return on; }
struct OmegaRs {
  Eigen::Vector2d ref, obs;
  double cx, cy, row_ref, row_obs, rate_n, rate_m;
  int i, nb, m, r;
  std::vector<int> block;  // frame -> pose block index, -1 none (the reference: zero)
  int np;
  template <typename T>
  bool operator()(T const* const* prm, T* residuals) const {
    auto P = [&](int frame, int c) -> T {
      return block[frame] < 0 ? T(0.0) : prm[1 + block[frame]][c];
    };
    const T* intr = prm[0];
    const T* omega_i = prm[1 + np];
    const T* omega_r = prm[2 + np];
    const T& w = prm[3 + np][0];
    const T& readout = prm[4 + np][0];
    T p[3];
    PixelToUndistorted(intr[0], intr[1], intr[2], cx, cy, ref.x(), ref.y(), &p[0], &p[1]);
    p[2] = T(1.0);
    const T a_r = readout * row_ref;
    T minus_rotation[3], shifted[3];
    for (int k = 0; k < 3; ++k) {
      minus_rotation[k] = -a_r * omega_r[k];
      shifted[k] = p[k] - w * a_r * rate_m * P(m, 3 + k);
    }
    T wX[3];
    ceres::AngleAxisRotatePoint(minus_rotation, shifted, wX);
    const T a_i = readout * row_obs;
    T row_pose[6];
    for (int k = 0; k < 3; ++k) {
      row_pose[k] = P(i, k) + a_i * omega_i[k];
      row_pose[3 + k] = P(i, 3 + k) + a_i * rate_n * (P(nb, 3 + k) - P(i, 3 + k));
    }
    T X[3];
    ceres::AngleAxisRotatePoint(row_pose, wX, X);
    for (int k = 0; k < 3; ++k) X[k] += w * row_pose[3 + k];
    UndistortedResidual(intr, cx, cy, obs, X, residuals);
    return true;
  }
};

// n: frame i's neighbour on the side of its observed row; m: the reference's.
struct Reprojection::Sides {
  Neighbour n, m;
};

Reprojection::Sides Reprojection::SidesOf(int j, int i, const Eigen::Vector2d& reference) const {
  const int frames = tracks_.num_frames();
  const double dt_i = RowTime(1.0, tracks_.pixels[i](1, j), camera_.height);
  const double dt_r = RowTime(1.0, reference.y(), camera_.height);
  return {NeighbourOnSide(i, dt_i, frames, times_),
          NeighbourOnSide(tracks_.reference, dt_r, frames, times_)};
}

OmegaRs Reprojection::MakeOmega(int j, int i, const Eigen::Vector2d& reference,
                                const Sides& sides) const {
  OmegaRs e;
  e.ref = reference;
  e.obs = tracks_.pixels[i].col(j);
  e.cx = camera_.cx; e.cy = camera_.cy;
  e.row_ref = RowTime(1.0, reference.y(), camera_.height);
  e.row_obs = RowTime(1.0, e.obs.y(), camera_.height);
  e.rate_n = sides.n.rate; e.rate_m = sides.m.rate;
  e.i = i; e.nb = sides.n.frame; e.m = sides.m.frame; e.r = tracks_.reference;
  e.block.assign(tracks_.num_frames(), -1);
  int np = 0;
  for (int k : {i, sides.n.frame, sides.m.frame})
    if (k != e.r && e.block[k] < 0) e.block[k] = np++;
  e.np = np;
  return e;
}

ceres::ResidualBlockId Reprojection::Add(ceres::Problem* problem, ceres::LossFunction* loss, int j,
                                         int i, double* intrinsics,
                                         std::vector<std::array<double, 6>>* poses,
                                         double* inverse_depth, double* readout) const {
  const Eigen::Vector2d reference = tracks_.pixels[tracks_.reference].col(j);
  const Eigen::Vector2d observed = tracks_.pixels[i].col(j);
  if (!rolling_)
    return problem->AddResidualBlock(
        UndistortedReprojectionError::Create(reference, observed, camera_.cx, camera_.cy), loss,
        intrinsics, (*poses)[i].data(), inverse_depth);
  if (ScratchSmooth()) {
    std::vector<int> frames;
    SmoothRs e = MakeSmooth(tracks_, camera_, j, i, reference, &frames);
    auto* cost = new ceres::DynamicAutoDiffCostFunction<SmoothRs, 4>(new SmoothRs(e));
    std::vector<double*> blocks = {intrinsics};
    cost->AddParameterBlock(3);
    for (int k : frames) { cost->AddParameterBlock(6); blocks.push_back((*poses)[k].data()); }
    cost->AddParameterBlock(1); blocks.push_back(inverse_depth);
    cost->AddParameterBlock(1); blocks.push_back(readout);
    cost->SetNumResiduals(2);
    return problem->AddResidualBlock(cost, loss, blocks);
  }
  if (ScratchOmega() && omega_) {
    const Sides sides = SidesOf(j, i, reference);
    OmegaRs e = MakeOmega(j, i, reference, sides);
    auto* cost = new ceres::DynamicAutoDiffCostFunction<OmegaRs, 4>(new OmegaRs(e));
    std::vector<double*> blocks = {intrinsics};
    cost->AddParameterBlock(3);
    for (int k = 0; k < e.np; ++k) cost->AddParameterBlock(6);
    for (int f = 0; f < tracks_.num_frames(); ++f) if (e.block[f] >= 0) blocks.push_back(nullptr);
    for (int f = 0; f < tracks_.num_frames(); ++f) if (e.block[f] >= 0) blocks[1 + e.block[f]] = (*poses)[f].data();
    cost->AddParameterBlock(3); blocks.push_back((*omega_)[i].data());
    cost->AddParameterBlock(3); blocks.push_back((*omega_)[tracks_.reference].data());
    cost->AddParameterBlock(1); blocks.push_back(inverse_depth);
    cost->AddParameterBlock(1); blocks.push_back(readout);
    cost->SetNumResiduals(2);
    return problem->AddResidualBlock(cost, loss, blocks);
  }
  const Sides sides = SidesOf(j, i, reference);
  using Shared = RollingShutterReprojectionError::ReferenceNeighbour;
  const Shared shared = sides.m.frame == i               ? Shared::kFrame
                        : sides.m.frame == sides.n.frame ? Shared::kFrameNeighbour
                                                         : Shared::kOwnBlock;
  std::vector<double*> blocks = {intrinsics, (*poses)[i].data(), (*poses)[sides.n.frame].data()};
  if (shared == Shared::kOwnBlock) blocks.push_back((*poses)[sides.m.frame].data());
  blocks.push_back(inverse_depth);
  blocks.push_back(readout);
  const RollingShutterReprojectionError error(reference, observed, camera_.cx, camera_.cy,
                                              camera_.height, sides.m.rate, sides.n.rate);
  return problem->AddResidualBlock(new RollingShutterCostFunction(error, shared), loss, blocks);
}

void Reprojection::Evaluate(int j, int i, const Eigen::Vector2d& reference,
                            const double* intrinsics,
                            const std::vector<std::array<double, 6>>& poses,
                            const double* inverse_depth, const double* readout,
                            double* residual) const {
  const Eigen::Vector2d observed = tracks_.pixels[i].col(j);
  if (!rolling_) {
    UndistortedReprojectionError(reference, observed, camera_.cx, camera_.cy)(
        intrinsics, poses[i].data(), inverse_depth, residual);
    return;
  }
  if (ScratchSmooth()) {
    std::vector<int> frames;
    SmoothRs e = MakeSmooth(tracks_, camera_, j, i, reference, &frames);
    std::vector<const double*> prm = {intrinsics};
    for (int k : frames) prm.push_back(poses[k].data());
    prm.push_back(inverse_depth);
    prm.push_back(readout);
    e(prm.data(), residual);
    return;
  }
  if (ScratchOmega() && omega_) {
    const Sides sides = SidesOf(j, i, reference);
    OmegaRs e = MakeOmega(j, i, reference, sides);
    std::vector<const double*> prm(1 + e.np + 4);
    prm[0] = intrinsics;
    for (int f = 0; f < tracks_.num_frames(); ++f) if (e.block[f] >= 0) prm[1 + e.block[f]] = poses[f].data();
    prm[1 + e.np] = (*omega_)[i].data();
    prm[2 + e.np] = (*omega_)[tracks_.reference].data();
    prm[3 + e.np] = inverse_depth;
    prm[4 + e.np] = readout;
    e(prm.data(), residual);
    return;
  }
  const Sides sides = SidesOf(j, i, reference);
  RollingShutterReprojectionError(reference, observed, camera_.cx, camera_.cy, camera_.height,
                                  sides.m.rate, sides.n.rate)
      .Evaluate(intrinsics, poses[i].data(), poses[sides.n.frame].data(),
                poses[sides.m.frame].data(), inverse_depth, readout, residual);
}

std::array<double, 6> ToParameters(const Pose& pose) {
  std::array<double, 6> parameters;
  Eigen::Map<PoseParameters>(parameters.data()) = ToPoseParameters(pose);
  return parameters;
}

Pose FromParameters(const std::array<double, 6>& parameters) {
  return FromPoseParameters(Eigen::Map<const PoseParameters>(parameters.data()));
}

namespace {

// The track whose inverse depth is held constant to fix the scale gauge: the
// used track closest to the median inverse depth.
int ScaleAnchor(const std::vector<double>& inverse_depths, const std::vector<bool>& use) {
  std::vector<double> used;
  for (size_t j = 0; j < inverse_depths.size(); ++j)
    if (use[j]) used.push_back(inverse_depths[j]);
  std::nth_element(used.begin(), used.begin() + used.size() / 2, used.end());
  const double median = used[used.size() / 2];
  int anchor = -1;
  for (size_t j = 0; j < inverse_depths.size(); ++j)
    if (use[j] && (anchor < 0 || std::abs(inverse_depths[j] - median) <
                                     std::abs(inverse_depths[anchor] - median)))
      anchor = static_cast<int>(j);
  return anchor;
}

}  // namespace

void AddReprojectionResiduals(const FeatureTracks& tracks, const std::vector<bool>& use,
                              const Reprojection& reprojection,
                              const AdjustmentParameters& parameters, ceres::HuberLoss* huber,
                              std::vector<std::unique_ptr<ceres::ScaledLoss>>* weighted_losses,
                              ceres::Problem* problem, ceres::ParameterBlockOrdering* ordering,
                              AdjustmentResidualBlocks* blocks) {
  const int n = tracks.num_frames();
  const int m = tracks.num_tracks();
  std::vector<double>& inverse_depths = *parameters.inverse_depths;
  for (int j = 0; j < m; ++j) {
    if (!use[j]) continue;
    ceres::LossFunction* loss = huber;
    if (tracks.weight(j) != 1.0) {
      weighted_losses->push_back(std::make_unique<ceres::ScaledLoss>(huber, tracks.weight(j),
                                                                     ceres::DO_NOT_TAKE_OWNERSHIP));
      loss = weighted_losses->back().get();
    }
    for (int i = 0; i < n; ++i) {
      if (i == tracks.reference) continue;
      blocks->track_frame.emplace_back(j, i);
      blocks->reprojection.push_back(reprojection.Add(problem, loss, j, i, parameters.intrinsics,
                                                      parameters.poses, &inverse_depths[j],
                                                      parameters.readout));
    }
    // Inverse depths first: Schur eliminates them, leaving a small dense
    // system over the poses and intrinsics.
    ordering->AddElementToGroup(&inverse_depths[j], 0);
  }
}

void AddIntrinsicsPriors(const CameraModel& camera, const BundleAdjustmentOptions& options,
                         double* intrinsics, ceres::Problem* problem,
                         std::vector<ceres::ResidualBlockId>* prior) {
  if (options.log_f_prior_sigma > 0.0)
    prior->push_back(
        problem->AddResidualBlock(IntrinsicsPrior::Create(camera, options.log_f_prior_sigma,
                                                          options.corner_shift_prior_sigma),
                                  nullptr, intrinsics));
  if (options.lens_k_prior_sigma > 0.0)
    prior->push_back(problem->AddResidualBlock(LensPrior::Create(options.lens_k_prior_sigma),
                                               nullptr, intrinsics));
  if (options.HasKnownIntrinsicsPrior())
    prior->push_back(problem->AddResidualBlock(
        KnownIntrinsicsPrior::Create(camera, options.known_f_sigma_percent,
                                     options.known_distortion_sigma_px),
        nullptr, intrinsics));
}

int FixBurstGauge(const FeatureTracks& tracks, const std::vector<bool>& use,
                  const AdjustmentParameters& parameters, ceres::Problem* problem,
                  ceres::ParameterBlockOrdering* ordering) {
  std::vector<std::array<double, 6>>& poses = *parameters.poses;
  for (int i = 0; i < tracks.num_frames(); ++i)
    if (i != tracks.reference) ordering->AddElementToGroup(poses[i].data(), 1);
  // With a rolling shutter the reference's pose is a neighbour's: held at R =
  // I, T = 0.
  if (problem->HasParameterBlock(poses[tracks.reference].data())) {
    problem->SetParameterBlockConstant(poses[tracks.reference].data());
    ordering->AddElementToGroup(poses[tracks.reference].data(), 1);
  }
  std::vector<double>& inverse_depths = *parameters.inverse_depths;
  const int anchor = ScaleAnchor(inverse_depths, use);
  if (getenv("DFSM_SCRATCH_HOLD_T")) {
    for (int i = 0; i < tracks.num_frames(); ++i)
      if (i != tracks.reference && problem->HasParameterBlock(poses[i].data()))
        problem->SetManifold(poses[i].data(), new ceres::SubsetManifold(6, {3, 4, 5}));
    return anchor;
  }
  problem->SetParameterBlockConstant(&inverse_depths[anchor]);
  return anchor;
}

void ConstrainCamera(const BundleAdjustmentOptions& options, bool rolling, double* intrinsics,
                     double* readout, ceres::Problem* problem,
                     ceres::ParameterBlockOrdering* ordering) {
  ordering->AddElementToGroup(intrinsics, 1);
  if (rolling) {
    ordering->AddElementToGroup(readout, 1);
    if (options.estimate_readout) {
      problem->SetParameterLowerBound(readout, 0, -kMaxReadout);
      problem->SetParameterUpperBound(readout, 0, kMaxReadout);
    } else {
      problem->SetParameterBlockConstant(readout);
    }
  }
  if (options.fix_intrinsics)
    problem->SetParameterBlockConstant(intrinsics);
  else if (options.distortion_terms == 1)
    problem->SetManifold(intrinsics, new ceres::SubsetManifold(3, {2}));
  else if (options.distortion_terms == 0)
    problem->SetManifold(intrinsics, new ceres::SubsetManifold(3, {1, 2}));
}

ceres::Solver::Summary SolveAdjustment(const BundleAdjustmentOptions& options,
                                       ceres::ParameterBlockOrdering* ordering,
                                       ceres::Problem* problem, ceres::LinearSolverType solver) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = solver;
  solver_options.linear_solver_ordering.reset(ordering);
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads = options.num_threads;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, problem, &summary);
  return summary;
}

AdjustmentJacobians EvaluateJacobians(ceres::Problem* problem, double* intrinsics,
                                      const std::vector<double*>& poses, double* readout,
                                      const std::vector<double*>& depths,
                                      const std::vector<ceres::ResidualBlockId>& reprojection,
                                      const std::vector<ceres::ResidualBlockId>& prior) {
  AdjustmentJacobians jacobians;
  ceres::Problem::EvaluateOptions evaluate;
  if (!problem->IsParameterBlockConstant(intrinsics)) {
    evaluate.parameter_blocks.push_back(intrinsics);
    jacobians.intrinsics_columns = problem->ParameterBlockTangentSize(intrinsics);
    // The refined terms come first: f, then k1 and k2 as distortion_terms
    // leaves them free (SubsetManifold keeps the order of the others).
    for (int column = 0; column < jacobians.intrinsics_columns; ++column)
      jacobians.intrinsics_indices.push_back(column);
  }
  for (double* pose : poses) evaluate.parameter_blocks.push_back(pose);
  jacobians.camera_columns = jacobians.intrinsics_columns + 6 * static_cast<int>(poses.size());
  if (problem->HasParameterBlock(readout) && !problem->IsParameterBlockConstant(readout)) {
    evaluate.parameter_blocks.push_back(readout);
    jacobians.readout_column = jacobians.camera_columns++;
  }
  for (double* depth : depths) evaluate.parameter_blocks.push_back(depth);
  evaluate.residual_blocks = reprojection;
  problem->Evaluate(evaluate, nullptr, &jacobians.reprojection_residuals, nullptr,
                    &jacobians.reprojection);
  if (!prior.empty()) {
    evaluate.residual_blocks = prior;
    problem->Evaluate(evaluate, nullptr, nullptr, nullptr, &jacobians.prior);
  }
  return jacobians;
}

void AddReferenceJacobians(const FeatureTracks& tracks, const Reprojection& reprojection,
                           const AdjustmentParameters& parameters,
                           const AdjustmentResidualBlocks& blocks, int first_track,
                           AdjustmentJacobians* jacobians) {
  const std::vector<std::array<double, 6>>& poses = *parameters.poses;
  const std::vector<double>& inverse_depths = *parameters.inverse_depths;
  // A tenth of a millipixel: the residual is smooth and this only scales a
  // covariance.
  constexpr double kStep = 1e-4;
  for (const auto& [j, i] : blocks.track_frame) {
    Eigen::Matrix2d B;
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector2d plus = tracks.pixels[tracks.reference].col(j);
      Eigen::Vector2d minus = plus;
      plus[axis] += kStep;
      minus[axis] -= kStep;
      double r_plus[2], r_minus[2];
      reprojection.Evaluate(j, i, plus, parameters.intrinsics, poses, &inverse_depths[j],
                            parameters.readout, r_plus);
      reprojection.Evaluate(j, i, minus, parameters.intrinsics, poses, &inverse_depths[j],
                            parameters.readout, r_minus);
      for (int k = 0; k < 2; ++k) B(k, axis) = (r_plus[k] - r_minus[k]) / (2.0 * kStep);
    }
    // Whitened like the residuals the problem evaluates (its loss applied).
    B *= std::sqrt(tracks.weight(j));
    jacobians->block_track.push_back(first_track + j);
    jacobians->reference_jacobians.push_back(B);
  }
}

}  // namespace dfsm
