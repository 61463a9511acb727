#include "core/sparse/bundle_adjustment.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "core/camera/rolling_shutter.h"
#include "core/sparse/adjustment_problem.h"

namespace dfsm {
namespace {

// The state's angular velocities as parameter blocks, started from the
// neighbours' rotation step where the state has none for its frames.
std::vector<std::array<double, 3>> AngularVelocityBlocks(const SparseState& state) {
  const int n = static_cast<int>(state.poses.size());
  std::vector<std::array<double, 3>> blocks(n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d velocity;
    if (static_cast<int>(state.angular_velocities.size()) == n) {
      velocity = state.angular_velocities[i];
    } else {
      const StepAcross step = StepAcrossFrame(i, n, state.frame_times);
      velocity = step.rate * (ToPoseParameters(state.poses[step.after]).head<3>() -
                              ToPoseParameters(state.poses[step.before]).head<3>());
    }
    blocks[i] = {velocity.x(), velocity.y(), velocity.z()};
  }
  return blocks;
}

// The marginal covariance of the intrinsics at the solution
// (calibration_uncertainty.h), `camera` the refined one.
void ComputeAdjustmentUncertainty(const FeatureTracks& tracks, const std::vector<bool>& use,
                                  const CameraModel& camera, const BundleAdjustmentOptions& options,
                                  const Reprojection& reprojection,
                                  const AdjustmentParameters& parameters,
                                  std::vector<std::array<double, 3>>* velocities, int anchor,
                                  const AdjustmentResidualBlocks& blocks, ceres::Problem* problem,
                                  CalibrationUncertainty* uncertainty) {
  std::vector<double*> poses, depths;
  for (int i = 0; i < tracks.num_frames(); ++i)
    if (i != tracks.reference) poses.push_back((*parameters.poses)[i].data());
  std::vector<double>& inverse_depths = *parameters.inverse_depths;
  for (size_t j = 0; j < inverse_depths.size(); ++j)
    if (use[j] && static_cast<int>(j) != anchor) depths.push_back(&inverse_depths[j]);
  std::vector<double*> angular_velocities;
  for (std::array<double, 3>& velocity : *velocities) angular_velocities.push_back(velocity.data());
  AdjustmentJacobians jacobians =
      EvaluateJacobians(problem, parameters.intrinsics, poses, parameters.readout,
                        angular_velocities, depths, blocks.reprojection, blocks.prior);
  AddReferenceJacobians(tracks, reprojection, parameters, blocks, 0, &jacobians);
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
  if (uncertainty && options.hold_inverse_depths)
    throw std::invalid_argument("no covariance of an adjustment whose inverse depths are held");
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
  Reprojection reprojection(tracks, state->camera, readout != 0.0 || options.estimate_readout,
                            state->frame_times);
  std::vector<std::array<double, 3>> velocities;
  if (options.angular_velocity_sigma_px > 0.0 && reprojection.rolling()) {
    velocities = AngularVelocityBlocks(*state);
    reprojection.UseAngularVelocities(&velocities);
  }
  AddReprojectionResiduals(tracks, use, reprojection, parameters, &huber, &weighted_losses,
                           &problem, ordering, &blocks);
  AddIntrinsicsPriors(state->camera, options, intrinsics, &problem, &blocks.prior);
  const int anchor = FixBurstGauge(tracks, use, parameters, &problem, ordering);
  if (options.hold_inverse_depths) HoldInverseDepths(use, parameters, &problem);
  ConstrainCamera(options, reprojection.rolling(), intrinsics, &readout, &problem, ordering);
  if (reprojection.HasAngularVelocities())
    AddAngularVelocityPriors(tracks, state->camera, state->frame_times,
                             options.angular_velocity_sigma_px, parameters, &velocities, &problem,
                             ordering, &blocks.prior);
  const ceres::Solver::Summary summary = SolveAdjustment(options, ordering, &problem);

  state->camera.f = intrinsics[0];
  state->camera.k1 = intrinsics[1];
  state->camera.k2 = intrinsics[2];
  state->readout = readout;
  if (uncertainty)
    ComputeAdjustmentUncertainty(tracks, use, state->camera, options, reprojection, parameters,
                                 &velocities, anchor, blocks, &problem, uncertainty);
  for (int i = 0; i < n; ++i)
    state->poses[i] = i == tracks.reference ? Pose{} : FromParameters(poses[i]);
  state->angular_velocities.clear();
  for (const std::array<double, 3>& velocity : velocities)
    state->angular_velocities.emplace_back(velocity[0], velocity[1], velocity[2]);
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
    if (state.angular_velocities.size() == state.poses.size()) {
      for (const Eigen::Vector3d& velocity : state.angular_velocities)
        velocities_.push_back({velocity.x(), velocity.y(), velocity.z()});
      reprojection_.UseAngularVelocities(&velocities_);
    }
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
  std::vector<std::array<double, 3>> velocities_;
  Reprojection reprojection_;
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
  if (!(angular_velocity_sigma_px >= 0.0))
    refuse("angular_velocity_sigma_px must be >= 0 (0: the line between frame poses)");
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
