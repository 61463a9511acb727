#include "core/sparse/adjustment_problem.h"

#include <algorithm>
#include <cmath>

#include "core/camera/rolling_shutter.h"
#include "core/sparse/angular_velocity_cost_function.h"
#include "core/sparse/angular_velocity_reprojection_error.h"
#include "core/sparse/intrinsics_prior.h"
#include "core/sparse/rolling_shutter_cost_function.h"
#include "core/sparse/rolling_shutter_reprojection_error.h"
#include "core/sparse/undistorted_reprojection_error.h"

namespace dfsm {

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
  const Sides sides = SidesOf(j, i, reference);
  using Shared = RollingShutterReprojectionError::ReferenceNeighbour;
  const Shared shared = sides.m.frame == i               ? Shared::kFrame
                        : sides.m.frame == sides.n.frame ? Shared::kFrameNeighbour
                                                         : Shared::kOwnBlock;
  std::vector<double*> blocks = {intrinsics, (*poses)[i].data(), (*poses)[sides.n.frame].data()};
  if (shared == Shared::kOwnBlock) blocks.push_back((*poses)[sides.m.frame].data());
  if (velocities_) {
    blocks.push_back((*velocities_)[i].data());
    blocks.push_back((*velocities_)[tracks_.reference].data());
    blocks.push_back(inverse_depth);
    blocks.push_back(readout);
    const AngularVelocityReprojectionError error(reference, observed, camera_.cx, camera_.cy,
                                                 camera_.height, sides.m.rate, sides.n.rate);
    return problem->AddResidualBlock(new AngularVelocityCostFunction(error, shared), loss, blocks);
  }
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
  const Sides sides = SidesOf(j, i, reference);
  if (velocities_) {
    AngularVelocityReprojectionError(reference, observed, camera_.cx, camera_.cy, camera_.height,
                                     sides.m.rate, sides.n.rate)
        .Evaluate(intrinsics, poses[i].data(), poses[sides.n.frame].data(),
                  poses[sides.m.frame].data(), (*velocities_)[i].data(),
                  (*velocities_)[tracks_.reference].data(), inverse_depth, readout, residual);
    return;
  }
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
  problem->SetParameterBlockConstant(&inverse_depths[anchor]);
  return anchor;
}

void HoldInverseDepths(const std::vector<bool>& use, const AdjustmentParameters& parameters,
                       ceres::Problem* problem) {
  std::vector<double>& inverse_depths = *parameters.inverse_depths;
  for (size_t j = 0; j < inverse_depths.size(); ++j)
    if (use[j]) problem->SetParameterBlockConstant(&inverse_depths[j]);
}

StepAcross StepAcrossFrame(int frame, int frames, const std::vector<double>& times) {
  const int after = std::min(frame + 1, frames - 1), before = std::max(frame - 1, 0);
  const double span = times.empty() ? after - before : times[after] - times[before];
  return {after, before, 1.0 / span};
}

void AddAngularVelocityPriors(const FeatureTracks& tracks, const CameraModel& camera,
                              const std::vector<double>& times, double sigma_px,
                              const AdjustmentParameters& parameters,
                              std::vector<std::array<double, 3>>* velocities,
                              ceres::Problem* problem, ceres::ParameterBlockOrdering* ordering,
                              std::vector<ceres::ResidualBlockId>* prior) {
  const int n = tracks.num_frames();
  for (int i = 0; i < n; ++i) {
    const StepAcross step = StepAcrossFrame(i, n, times);
    std::vector<double*> blocks = {(*velocities)[i].data()};
    const bool after_is_block = step.after != tracks.reference,
               before_is_block = step.before != tracks.reference;
    if (after_is_block) blocks.push_back((*parameters.poses)[step.after].data());
    if (before_is_block) blocks.push_back((*parameters.poses)[step.before].data());
    prior->push_back(
        problem->AddResidualBlock(AngularVelocityPrior::Create(camera.f / sigma_px, step.rate,
                                                               after_is_block, before_is_block),
                                  nullptr, blocks));
    ordering->AddElementToGroup((*velocities)[i].data(), 1);
  }
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
                                      const std::vector<double*>& angular_velocities,
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
  for (double* velocity : angular_velocities) {
    evaluate.parameter_blocks.push_back(velocity);
    jacobians.camera_columns += 3;
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
