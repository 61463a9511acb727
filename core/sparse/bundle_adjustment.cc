#include "core/sparse/bundle_adjustment.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "core/camera/rolling_shutter.h"
#include "core/sparse/intrinsics_prior.h"
#include "core/sparse/rolling_shutter_cost_function.h"
#include "core/sparse/rolling_shutter_reprojection_error.h"
#include "core/sparse/undistorted_reprojection_error.h"

namespace dfsm {
namespace {

// The reprojection residual of one observation (track j in frame i) under the
// state's shutter: UndistortedReprojectionError for a global shutter,
// RollingShutterReprojectionError, with the poses of frame i's and the
// reference's neighbours, otherwise.
class Reprojection {
 public:
  // times: the frames' capture times (SparseState::frame_times).
  Reprojection(const FeatureTracks& tracks, const CameraModel& camera, bool rolling,
               const std::vector<double>& times)
      : tracks_(tracks), camera_(camera), rolling_(rolling), times_(times) {}

  bool rolling() const { return rolling_; }

  // Adds the residual of track j in frame i over `poses` (angle-axis, T per
  // frame; the reference's block, when a neighbour, must be held constant).
  ceres::ResidualBlockId Add(ceres::Problem* problem, ceres::LossFunction* loss, int j, int i,
                             double* intrinsics, std::vector<std::array<double, 6>>* poses,
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
    blocks.push_back(inverse_depth);
    blocks.push_back(readout);
    return problem->AddResidualBlock(
        new RollingShutterCostFunction(Error(sides, reference, observed), shared), loss, blocks);
  }

  // The residual at the given parameters, with the reference pixel of track j
  // replaced by `reference` (for d residual / d reference pixel).
  void Evaluate(int j, int i, const Eigen::Vector2d& reference, const double* intrinsics,
                const std::vector<std::array<double, 6>>& poses, const double* inverse_depth,
                const double* readout, double* residual) const {
    const Eigen::Vector2d observed = tracks_.pixels[i].col(j);
    if (!rolling_) {
      UndistortedReprojectionError(reference, observed, camera_.cx, camera_.cy)(
          intrinsics, poses[i].data(), inverse_depth, residual);
      return;
    }
    const Sides sides = SidesOf(j, i, reference);
    Error(sides, reference, observed)
        .Evaluate(intrinsics, poses[i].data(), poses[sides.n.frame].data(),
                  poses[sides.m.frame].data(), inverse_depth, readout, residual);
  }

 private:
  // n: frame i's neighbour on the side of its observed row; m: the reference's.
  struct Sides {
    Neighbour n, m;
  };
  Sides SidesOf(int j, int i, const Eigen::Vector2d& reference) const {
    const int frames = tracks_.num_frames();
    const double dt_i = RowTime(1.0, tracks_.pixels[i](1, j), camera_.height);
    const double dt_r = RowTime(1.0, reference.y(), camera_.height);
    return {NeighbourOnSide(i, dt_i, frames, times_),
            NeighbourOnSide(tracks_.reference, dt_r, frames, times_)};
  }
  RollingShutterReprojectionError Error(const Sides& sides, const Eigen::Vector2d& reference,
                                        const Eigen::Vector2d& observed) const {
    return RollingShutterReprojectionError(reference, observed, camera_.cx, camera_.cy,
                                           camera_.height, sides.m.rate, sides.n.rate);
  }

  const FeatureTracks& tracks_;
  const CameraModel& camera_;
  bool rolling_;
  const std::vector<double>& times_;
};

// A pose as Ceres holds it: the 6 parameters of rolling_shutter.h's
// PoseParameters (angle-axis of R, then T) in a plain array.
std::array<double, 6> ToParameters(const Pose& pose) {
  std::array<double, 6> parameters;
  Eigen::Map<PoseParameters>(parameters.data()) = ToPoseParameters(pose);
  return parameters;
}

Pose FromParameters(const std::array<double, 6>& parameters) {
  return FromPoseParameters(Eigen::Map<const PoseParameters>(parameters.data()));
}

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

// The jacobians that MarginalIntrinsicsCovariance needs, at the current values
// of the problem's parameters: columns ordered intrinsics, poses, the readout
// (when estimated), inverse depths; the scale anchor and constant intrinsics
// left out (held constant).
AdjustmentJacobians EvaluateJacobians(ceres::Problem* problem, double* intrinsics,
                                      std::vector<std::array<double, 6>>* poses, int reference,
                                      double* readout, std::vector<double>* inverse_depths,
                                      const std::vector<bool>& use, int anchor,
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
  for (size_t i = 0; i < poses->size(); ++i)
    if (static_cast<int>(i) != reference) evaluate.parameter_blocks.push_back((*poses)[i].data());
  jacobians.camera_columns =
      jacobians.intrinsics_columns + 6 * (static_cast<int>(poses->size()) - 1);
  if (problem->HasParameterBlock(readout) && !problem->IsParameterBlockConstant(readout)) {
    evaluate.parameter_blocks.push_back(readout);
    jacobians.readout_column = jacobians.camera_columns++;
  }
  for (size_t j = 0; j < inverse_depths->size(); ++j)
    if (use[j] && static_cast<int>(j) != anchor)
      evaluate.parameter_blocks.push_back(&(*inverse_depths)[j]);
  evaluate.residual_blocks = reprojection;
  problem->Evaluate(evaluate, nullptr, &jacobians.reprojection_residuals, nullptr,
                    &jacobians.reprojection);
  if (!prior.empty()) {
    evaluate.residual_blocks = prior;
    problem->Evaluate(evaluate, nullptr, nullptr, nullptr, &jacobians.prior);
  }
  return jacobians;
}

namespace {

// The adjustment's parameter blocks, which the problem points into: the
// locals of RunBundleAdjustment (the inverse depths are the state's). Held
// by pointer rather than gathered here because Ceres orders the blocks of
// an ordering group by address: moving them would change the order of the
// Schur complement's arithmetic.
struct AdjustmentParameters {
  double* intrinsics;                         // f, k1, k2
  std::vector<std::array<double, 6>>* poses;  // per frame (ToParameters)
  std::vector<double>* inverse_depths;        // per track
  double* readout;
};

// The residual blocks of the problem, in the order they were added: the
// covariance evaluates the jacobians of each kind apart.
struct AdjustmentResidualBlocks {
  std::vector<ceres::ResidualBlockId> reprojection, prior;
  std::vector<std::pair<int, int>> track_frame;  // (track, frame) of each reprojection block
};

// The problem's residuals: a reprojection per used observation (its track's
// weight scaling the Huber loss; the scaled losses go to `weighted_losses`,
// which the problem uses to its end), then the priors on the intrinsics.
// Each used inverse depth joins the ordering's group 0.
void AddAdjustmentResiduals(const FeatureTracks& tracks, const std::vector<bool>& use,
                            const CameraModel& camera, const BundleAdjustmentOptions& options,
                            const Reprojection& reprojection,
                            const AdjustmentParameters& parameters, ceres::HuberLoss* huber,
                            std::vector<std::unique_ptr<ceres::ScaledLoss>>* weighted_losses,
                            ceres::Problem* problem, ceres::ParameterBlockOrdering* ordering,
                            AdjustmentResidualBlocks* blocks) {
  const int n = tracks.num_frames();
  const int m = tracks.num_tracks();
  double* intrinsics = parameters.intrinsics;
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
      blocks->reprojection.push_back(reprojection.Add(problem, loss, j, i, intrinsics,
                                                      parameters.poses, &inverse_depths[j],
                                                      parameters.readout));
    }
    // Inverse depths first: Schur eliminates them, leaving a small dense
    // system over the poses and intrinsics.
    ordering->AddElementToGroup(&inverse_depths[j], 0);
  }
  if (options.log_f_prior_sigma > 0.0)
    blocks->prior.push_back(
        problem->AddResidualBlock(IntrinsicsPrior::Create(camera, options.log_f_prior_sigma,
                                                          options.corner_shift_prior_sigma),
                                  nullptr, intrinsics));
  if (options.lens_k_prior_sigma > 0.0)
    blocks->prior.push_back(problem->AddResidualBlock(LensPrior::Create(options.lens_k_prior_sigma),
                                                      nullptr, intrinsics));
  if (options.HasKnownIntrinsicsPrior())
    blocks->prior.push_back(problem->AddResidualBlock(
        KnownIntrinsicsPrior::Create(camera, options.known_f_sigma_percent,
                                     options.known_distortion_sigma_px),
        nullptr, intrinsics));
}

// What the problem holds: the poses, intrinsics and readout join the
// ordering's group 1; the gauge is fixed (the reference's pose where it is a
// block, the scale anchor's inverse depth) and the intrinsics and readout
// the options do not refine are held. Returns the scale anchor.
int ConstrainAdjustmentParameters(const FeatureTracks& tracks, const std::vector<bool>& use,
                                  const BundleAdjustmentOptions& options, bool rolling,
                                  const AdjustmentParameters& parameters, ceres::Problem* problem,
                                  ceres::ParameterBlockOrdering* ordering) {
  const int n = tracks.num_frames();
  double* intrinsics = parameters.intrinsics;
  std::vector<std::array<double, 6>>& poses = *parameters.poses;
  std::vector<double>& inverse_depths = *parameters.inverse_depths;
  double* readout = parameters.readout;
  for (int i = 0; i < n; ++i)
    if (i != tracks.reference) ordering->AddElementToGroup(poses[i].data(), 1);
  ordering->AddElementToGroup(intrinsics, 1);
  if (rolling) {
    // The reference's pose is a neighbour's: held at R = I, T = 0.
    if (problem->HasParameterBlock(poses[tracks.reference].data())) {
      problem->SetParameterBlockConstant(poses[tracks.reference].data());
      ordering->AddElementToGroup(poses[tracks.reference].data(), 1);
    }
    ordering->AddElementToGroup(readout, 1);
    if (options.estimate_readout) {
      problem->SetParameterLowerBound(readout, 0, -kMaxReadout);
      problem->SetParameterUpperBound(readout, 0, kMaxReadout);
    } else {
      problem->SetParameterBlockConstant(readout);
    }
  }
  const int anchor = ScaleAnchor(inverse_depths, use);
  problem->SetParameterBlockConstant(&inverse_depths[anchor]);
  if (options.fix_intrinsics)
    problem->SetParameterBlockConstant(intrinsics);
  else if (options.distortion_terms == 1)
    problem->SetManifold(intrinsics, new ceres::SubsetManifold(3, {2}));
  else if (options.distortion_terms == 0)
    problem->SetManifold(intrinsics, new ceres::SubsetManifold(3, {1, 2}));
  return anchor;
}

// Dense Schur over `ordering` (which the solver takes), silent: the caller
// reports the summary.
ceres::Solver::Summary SolveAdjustment(const BundleAdjustmentOptions& options,
                                       ceres::ParameterBlockOrdering* ordering,
                                       ceres::Problem* problem) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.linear_solver_ordering.reset(ordering);
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads = options.num_threads;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, problem, &summary);
  return summary;
}

// The marginal covariance of the intrinsics at the solution
// (calibration_uncertainty.h), `camera` the refined one: the problem's
// jacobians, and each reprojection block's derivative by its track's
// reference pixel, whose noise every residual of the track shares.
void ComputeAdjustmentUncertainty(const FeatureTracks& tracks, const std::vector<bool>& use,
                                  const CameraModel& camera, const BundleAdjustmentOptions& options,
                                  const Reprojection& reprojection,
                                  const AdjustmentParameters& parameters, int anchor,
                                  const AdjustmentResidualBlocks& blocks, ceres::Problem* problem,
                                  CalibrationUncertainty* uncertainty) {
  double* intrinsics = parameters.intrinsics;
  const std::vector<std::array<double, 6>>& poses = *parameters.poses;
  std::vector<double>& inverse_depths = *parameters.inverse_depths;
  double* readout = parameters.readout;
  AdjustmentJacobians jacobians =
      EvaluateJacobians(problem, intrinsics, parameters.poses, tracks.reference, readout,
                        &inverse_depths, use, anchor, blocks.reprojection, blocks.prior);
  // d residual / d reference pixel, by central differences (a tenth of a
  // millipixel: the residual is smooth and this only scales a covariance).
  constexpr double kStep = 1e-4;
  for (const auto& [j, i] : blocks.track_frame) {
    Eigen::Matrix2d B;
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector2d plus = tracks.pixels[tracks.reference].col(j);
      Eigen::Vector2d minus = plus;
      plus[axis] += kStep;
      minus[axis] -= kStep;
      double r_plus[2], r_minus[2];
      reprojection.Evaluate(j, i, plus, intrinsics, poses, &inverse_depths[j], readout, r_plus);
      reprojection.Evaluate(j, i, minus, intrinsics, poses, &inverse_depths[j], readout, r_minus);
      for (int k = 0; k < 2; ++k) B(k, axis) = (r_plus[k] - r_minus[k]) / (2.0 * kStep);
    }
    // Whitened like the residuals the problem evaluates (its loss applied).
    B *= std::sqrt(tracks.weight(j));
    jacobians.block_track.push_back(j);
    jacobians.reference_jacobians.push_back(B);
  }
  jacobians.noise_inflation = UncertaintyInflation(options, camera);
  jacobians.inverse_depths = inverse_depths;
  *uncertainty = MarginalIntrinsicsCovariance(jacobians);
  uncertainty->wide_angle_factor = WideAngleFactor(options, camera);
  PropagateToDistortion(camera, uncertainty);
}

// What result.json reports of the adjustment: Ceres' outcome, and the RMS
// reprojection error over the used tracks at the refined `state`.
BundleAdjustmentSummary SummariseAdjustment(const FeatureTracks& tracks,
                                            const std::vector<bool>& use, const SparseState& state,
                                            const ceres::Solver::Summary& summary) {
  BundleAdjustmentSummary result;
  result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.termination = ceres::TerminationTypeToString(summary.termination_type) +
                       std::string(": ") + summary.message;
  const int m = tracks.num_tracks();
  double sum = 0.0;
  int count = 0;
  const std::vector<double> errors = TrackReprojectionErrors(tracks, state);
  for (int j = 0; j < m; ++j)
    if (use[j]) sum += errors[j] * errors[j], ++count;
  result.rms_reprojection_px = count > 0 ? std::sqrt(sum / count) : 0.0;
  return result;
}

}  // namespace

BundleAdjustmentSummary RunBundleAdjustment(const FeatureTracks& tracks,
                                            const std::vector<bool>& use, SparseState* state,
                                            const BundleAdjustmentOptions& options,
                                            CalibrationUncertainty* uncertainty) {
  options.Check();
  const int n = tracks.num_frames();
  double intrinsics[3] = {state->camera.f, state->camera.k1, state->camera.k2};
  std::vector<std::array<double, 6>> poses(n);
  for (int i = 0; i < n; ++i) poses[i] = ToParameters(state->poses[i]);
  std::vector<double>& inverse_depths = state->inverse_depths;

  ceres::HuberLoss huber(options.huber_px);
  // A weighted track's loss scales the Huber loss (FeatureTracks::weights);
  // declared before the problem, which uses them to its end.
  std::vector<std::unique_ptr<ceres::ScaledLoss>> weighted_losses;
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  auto* ordering = new ceres::ParameterBlockOrdering;
  AdjustmentResidualBlocks blocks;
  double readout = state->readout;
  const AdjustmentParameters parameters = {intrinsics, &poses, &inverse_depths, &readout};
  const Reprojection reprojection(tracks, state->camera, readout != 0.0 || options.estimate_readout,
                                  state->frame_times);
  AddAdjustmentResiduals(tracks, use, state->camera, options, reprojection, parameters, &huber,
                         &weighted_losses, &problem, ordering, &blocks);
  const int anchor = ConstrainAdjustmentParameters(tracks, use, options, reprojection.rolling(),
                                                   parameters, &problem, ordering);
  const ceres::Solver::Summary summary = SolveAdjustment(options, ordering, &problem);

  state->camera.f = intrinsics[0];
  state->camera.k1 = intrinsics[1];
  state->camera.k2 = intrinsics[2];
  state->readout = readout;
  if (uncertainty)
    ComputeAdjustmentUncertainty(tracks, use, state->camera, options, reprojection, parameters,
                                 anchor, blocks, &problem, uncertainty);
  for (int i = 0; i < n; ++i)
    state->poses[i] = i == tracks.reference ? Pose{} : FromParameters(poses[i]);
  return SummariseAdjustment(tracks, use, *state, summary);
}

namespace {

// The reprojection of one state's camera and poses, track by track.
class TrackFit {
 public:
  TrackFit(const FeatureTracks& tracks, const SparseState& state)
      : tracks_(tracks),
        state_(state),
        intrinsics_{state.camera.f, state.camera.k1, state.camera.k2},
        reprojection_(tracks, state.camera, state.readout != 0.0, state.frame_times) {
    for (const Pose& pose : state.poses) poses_.push_back(ToParameters(pose));
  }

  // The residuals of track j in every frame but the reference, at inverse
  // depth w, one after the other (2 per frame).
  Eigen::VectorXd Residuals(int j, double w) const {
    const int n = tracks_.num_frames();
    Eigen::VectorXd residuals = Eigen::VectorXd::Zero(2 * std::max(0, n - 1));
    int k = 0;
    for (int i = 0; i < n; ++i) {
      if (i == tracks_.reference) continue;
      reprojection_.Evaluate(j, i, tracks_.pixels[tracks_.reference].col(j), intrinsics_, poses_,
                             &w, &state_.readout, residuals.data() + 2 * k++);
    }
    return residuals;
  }

  // RMS over the frames but the reference.
  double RmsError(const Eigen::VectorXd& residuals) const {
    const int n = tracks_.num_frames();
    return n > 1 ? std::sqrt(residuals.squaredNorm() / (n - 1)) : 0.0;
  }

 private:
  const FeatureTracks& tracks_;
  const SparseState& state_;
  const double intrinsics_[3];
  std::vector<std::array<double, 6>> poses_;
  const Reprojection reprojection_;
};

// Gauss-Newton steps on one inverse depth: the residuals are close to
// linear in it (a small motion moves a point along a line with w), so a
// few steps reach the minimum.
constexpr int kDepthRefitSteps = 5;

}  // namespace

std::vector<double> TrackReprojectionErrors(const FeatureTracks& tracks, const SparseState& state) {
  const TrackFit fit(tracks, state);
  std::vector<double> errors(tracks.num_tracks(), 0.0);
  for (int j = 0; j < tracks.num_tracks(); ++j)
    errors[j] = fit.RmsError(fit.Residuals(j, state.inverse_depths[j]));
  return errors;
}

std::vector<Eigen::Matrix2Xd> ObservationResiduals(const FeatureTracks& tracks,
                                                   const SparseState& state) {
  const TrackFit fit(tracks, state);
  const int n = tracks.num_frames(), m = tracks.num_tracks();
  std::vector<Eigen::Matrix2Xd> residuals(n, Eigen::Matrix2Xd::Zero(2, m));
  for (int j = 0; j < m; ++j) {
    const Eigen::VectorXd r = fit.Residuals(j, state.inverse_depths[j]);
    for (int i = 0, k = 0; i < n; ++i)
      if (i != tracks.reference) residuals[i].col(j) = r.segment<2>(2 * k++);
  }
  return residuals;
}

std::vector<double> TrackReprojectionErrorsAtBestDepth(const FeatureTracks& tracks,
                                                       const SparseState& state,
                                                       std::vector<double>* best_inverse_depths) {
  const TrackFit fit(tracks, state);
  std::vector<double> errors(tracks.num_tracks(), 0.0);
  if (best_inverse_depths) best_inverse_depths->assign(tracks.num_tracks(), 0.0);
  for (int j = 0; j < tracks.num_tracks(); ++j) {
    double w = state.inverse_depths[j];
    Eigen::VectorXd residuals = fit.Residuals(j, w);
    for (int step = 0; step < kDepthRefitSteps; ++step) {
      // d residuals / dw by a central difference, h relative to w.
      const double h = 1e-6 * std::max(std::abs(w), 1e-3);
      const Eigen::VectorXd slope = (fit.Residuals(j, w + h) - fit.Residuals(j, w - h)) / (2 * h);
      const double curvature = slope.squaredNorm();
      if (!(curvature > 0.0)) break;
      const double next = w - slope.dot(residuals) / curvature;
      const Eigen::VectorXd next_residuals = fit.Residuals(j, next);
      if (!(next_residuals.squaredNorm() < residuals.squaredNorm())) break;
      w = next;
      residuals = next_residuals;
    }
    errors[j] = fit.RmsError(residuals);
    if (best_inverse_depths) (*best_inverse_depths)[j] = w;
  }
  return errors;
}

void BundleAdjustmentOptions::Check() const {
  const auto refuse = [](const std::string& what) { throw std::invalid_argument(what); };
  if (max_iterations < 0) refuse("max_iterations must be >= 0 (0: evaluate the state only)");
  if (!(huber_px > 0.0)) refuse("huber_px must be > 0");
  if (!(function_tolerance > 0.0)) refuse("function_tolerance must be > 0");
  if (num_threads < 1) refuse("num_threads must be >= 1");
  if (distortion_terms < 0 || distortion_terms > 2)
    refuse("distortion_terms must be 0, 1 or 2 (k1, k2), got " + std::to_string(distortion_terms));
  if (!(log_f_prior_sigma >= 0.0)) refuse("log_f_prior_sigma must be >= 0 (0: off)");
  if (!(corner_shift_prior_sigma >= 0.0)) refuse("corner_shift_prior_sigma must be >= 0 (0: off)");
  if (!(lens_k_prior_sigma >= 0.0)) refuse("lens_k_prior_sigma must be >= 0 (0: off)");
  if (!(known_f_sigma_percent >= 0.0)) refuse("known_f_sigma_percent must be >= 0 (0: no prior)");
  if (!(known_distortion_sigma_px >= 0.0)) refuse("known_distortion_sigma_px must be >= 0");
  if (!(uncertainty_inflation >= 1.0)) refuse("uncertainty_inflation must be >= 1");
  if (!(wide_angle_focal_ratio >= 0.0)) refuse("wide_angle_focal_ratio must be >= 0 (0: off)");
  if (!(wide_angle_inflation_exponent >= 0.0)) refuse("wide_angle_inflation_exponent must be >= 0");
}

double WideAngleFactor(const BundleAdjustmentOptions& options, const CameraModel& camera) {
  const double side = std::max(camera.width, camera.height);
  const double ratio = camera.f > 0.0 && side > 0.0 ? camera.f / side : 0.0;
  // The bias it covers is the estimate's: a camera held or given as a prior
  // does not take it.
  const bool estimated = !options.fix_intrinsics && !options.HasKnownIntrinsicsPrior();
  if (!estimated || !(ratio > 0.0) || ratio >= options.wide_angle_focal_ratio ||
      options.wide_angle_inflation_exponent == 0.0)
    return 1.0;
  return std::pow(options.wide_angle_focal_ratio / ratio, options.wide_angle_inflation_exponent);
}

double UncertaintyInflation(const BundleAdjustmentOptions& options, const CameraModel& camera) {
  return options.uncertainty_inflation * WideAngleFactor(options, camera);
}

}  // namespace dfsm
