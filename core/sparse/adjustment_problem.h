// The pieces of the self-calibrating adjustment's Ceres problem that one
// burst's adjustment (bundle_adjustment.h) and the joint adjustment of several
// bursts of one camera (joint_adjustment.h) build alike: a burst's
// reprojection residuals over its own poses and inverse depths, its gauge, the
// camera's blocks and priors, and the jacobians the covariance reads. Within
// core/sparse only.
#pragma once

#include <ceres/ceres.h>

#include <array>
#include <memory>
#include <utility>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"
#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/calibration_uncertainty.h"
#include "core/sparse/feature_tracks.h"

namespace dfsm {

// The reprojection residual of one observation (track j in frame i) under the
// burst's shutter: UndistortedReprojectionError for a global shutter,
// RollingShutterReprojectionError, with the poses of frame i's and the
// reference's neighbours, otherwise; AngularVelocityReprojectionError where
// the frames' angular velocities are parameters too.
class Reprojection {
 public:
  // times: the frames' capture times (SparseState::frame_times).
  Reprojection(const FeatureTracks& tracks, const CameraModel& camera, bool rolling,
               const std::vector<double>& times)
      : tracks_(tracks), camera_(camera), rolling_(rolling), times_(times) {}

  bool rolling() const { return rolling_; }

  // With a rolling shutter, each frame's rows turn at its angular velocity
  // (one per frame, angle-axis per frame interval; must outlive this), not
  // along the line to its neighbour. Null: the line.
  void UseAngularVelocities(std::vector<std::array<double, 3>>* velocities) {
    velocities_ = rolling_ ? velocities : nullptr;
  }
  bool HasAngularVelocities() const { return velocities_ != nullptr; }

  // Adds the residual of track j in frame i over `poses` (angle-axis, T per
  // frame; the reference's block, when a neighbour, must be held constant).
  ceres::ResidualBlockId Add(ceres::Problem* problem, ceres::LossFunction* loss, int j, int i,
                             double* intrinsics, std::vector<std::array<double, 6>>* poses,
                             double* inverse_depth, double* readout) const;

  // The residual at the given parameters, with the reference pixel of track j
  // replaced by `reference` (for d residual / d reference pixel).
  void Evaluate(int j, int i, const Eigen::Vector2d& reference, const double* intrinsics,
                const std::vector<std::array<double, 6>>& poses, const double* inverse_depth,
                const double* readout, double* residual) const;

 private:
  struct Sides;
  Sides SidesOf(int j, int i, const Eigen::Vector2d& reference) const;

  const FeatureTracks& tracks_;
  const CameraModel& camera_;
  bool rolling_;
  const std::vector<double>& times_;
  std::vector<std::array<double, 3>>* velocities_ = nullptr;
};

// A pose as Ceres holds it: the 6 parameters of rolling_shutter.h's
// PoseParameters (angle-axis of R, then T) in a plain array.
std::array<double, 6> ToParameters(const Pose& pose);
Pose FromParameters(const std::array<double, 6>& parameters);

// The adjustment's parameter blocks, which the problem points into. Held by
// pointer rather than gathered by the problem's builder because Ceres orders
// the blocks of an ordering group by address: moving them would change the
// order of the Schur complement's arithmetic.
struct AdjustmentParameters {
  double* intrinsics;                         // f, k1, k2
  std::vector<std::array<double, 6>>* poses;  // per frame (ToParameters)
  std::vector<double>* inverse_depths;        // per track
  double* readout;
};

// One burst's residual blocks, in the order they were added: the covariance
// evaluates the jacobians of each kind apart.
struct AdjustmentResidualBlocks {
  std::vector<ceres::ResidualBlockId> reprojection, prior;
  std::vector<std::pair<int, int>> track_frame;  // (track, frame) of each reprojection block
};

// A reprojection residual per used observation of the burst (its track's
// weight scaling the Huber loss; the scaled losses go to `weighted_losses`,
// which the problem uses to its end). Each used inverse depth joins the
// ordering's group 0.
void AddReprojectionResiduals(const FeatureTracks& tracks, const std::vector<bool>& use,
                              const Reprojection& reprojection,
                              const AdjustmentParameters& parameters, ceres::HuberLoss* huber,
                              std::vector<std::unique_ptr<ceres::ScaledLoss>>* weighted_losses,
                              ceres::Problem* problem, ceres::ParameterBlockOrdering* ordering,
                              AdjustmentResidualBlocks* blocks);

// The priors the options put on the intrinsics, centred on `camera`.
void AddIntrinsicsPriors(const CameraModel& camera, const BundleAdjustmentOptions& options,
                         double* intrinsics, ceres::Problem* problem,
                         std::vector<ceres::ResidualBlockId>* prior);

// Holds every used track's inverse depth (BundleAdjustmentOptions::
// hold_inverse_depths: depths given from elsewhere, the gauge with them).
void HoldInverseDepths(const std::vector<bool>& use, const AdjustmentParameters& parameters,
                       ceres::Problem* problem);

// The burst's gauge: its poses join the ordering's group 1, the reference's
// pose is held where it is a block (a rolling shutter's neighbour), and the
// scale anchor's inverse depth is held. Returns the anchor.
int FixBurstGauge(const FeatureTracks& tracks, const std::vector<bool>& use,
                  const AdjustmentParameters& parameters, ceres::Problem* problem,
                  ceres::ParameterBlockOrdering* ordering);

// The frames across frame i whose rotations give its angular velocity's
// start and prior: the one after and the one before (i itself at the burst's
// ends), and rate = 1 / (t_after - t_before). times: SparseState::frame_times.
struct StepAcross {
  int after, before;
  double rate;
};
StepAcross StepAcrossFrame(int frame, int frames, const std::vector<double>& times);

// Ties each frame's angular velocity to its neighbours' rotation step
// (AngularVelocityPrior, `sigma_px` at the camera's f per frame interval,
// whitened; its residual blocks appended to `prior`); the velocities join
// the ordering's group 1.
void AddAngularVelocityPriors(const FeatureTracks& tracks, const CameraModel& camera,
                              const std::vector<double>& times, double sigma_px,
                              const AdjustmentParameters& parameters,
                              std::vector<std::array<double, 3>>* velocities,
                              ceres::Problem* problem, ceres::ParameterBlockOrdering* ordering,
                              std::vector<ceres::ResidualBlockId>* prior);

// The camera's blocks join the ordering's group 1 (the readout where the
// shutter rolls); what the options do not refine is held, the readout
// bounded to [-kMaxReadout, kMaxReadout] where it is.
void ConstrainCamera(const BundleAdjustmentOptions& options, bool rolling, double* intrinsics,
                     double* readout, ceres::Problem* problem,
                     ceres::ParameterBlockOrdering* ordering);

// Schur over `ordering` (which the solver takes), silent: the caller
// reports the summary. Dense suits one burst's few poses; the joint problem's
// reduced system is an arrow of per-burst blocks, which a sparse one suits.
ceres::Solver::Summary SolveAdjustment(const BundleAdjustmentOptions& options,
                                       ceres::ParameterBlockOrdering* ordering,
                                       ceres::Problem* problem,
                                       ceres::LinearSolverType solver = ceres::DENSE_SCHUR);

// The jacobians that MarginalIntrinsicsCovariance needs, at the current values
// of the problem's parameters: columns ordered intrinsics (where not held),
// `poses` (the free pose blocks), the readout (where estimated), the frames'
// `angular_velocities` (where the rows turn at them: parameters of the
// camera's motion like the poses, whose freedom the covariance and the
// relief's sigma have to count), `depths` (the free inverse depths).
AdjustmentJacobians EvaluateJacobians(ceres::Problem* problem, double* intrinsics,
                                      const std::vector<double*>& poses, double* readout,
                                      const std::vector<double*>& angular_velocities,
                                      const std::vector<double*>& depths,
                                      const std::vector<ceres::ResidualBlockId>& reprojection,
                                      const std::vector<ceres::ResidualBlockId>& prior);

// Appends to `jacobians` each reprojection block's derivative by its track's
// reference pixel, whose noise every residual of the track shares (by
// central differences), and its track as `first_track` + j.
void AddReferenceJacobians(const FeatureTracks& tracks, const Reprojection& reprojection,
                           const AdjustmentParameters& parameters,
                           const AdjustmentResidualBlocks& blocks, int first_track,
                           AdjustmentJacobians* jacobians);

}  // namespace dfsm
