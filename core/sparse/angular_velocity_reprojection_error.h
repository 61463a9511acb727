// RollingShutterReprojectionError with each frame's own angular velocity (Im
// et al., ICCV 2015: a velocity per frame; core/camera/rolling_shutter.h). The
// rows of frame i turn at omega_i about its middle row's rotation r_i, while
// the translation keeps the line to the neighbour n on the observed row's
// side:
//
//     P_ref(dt_r) = [dt_r * omega_ref,  dt_r * s_r * T_m],     (the reference's pose is 0)
//     P_i(dt_i)   = [r_i + dt_i * omega_i,  T_i + dt_i * s_i * (T_n - T_i)],
//
// dt, n, m and s as in rolling_shutter_reprojection_error.h. A hand's tremor
// reverses the camera's turn within a frame's readout, which the line through
// the neighbours' rotations cannot follow; left to the line, that motion
// goes into the translations and the relief (docs/experiments/021).
//
// AngularVelocityPrior ties omega_i to the rotation step of its neighbours,
// (r_a - r_b) / (t_a - t_b), with a sigma in pixels at f per frame interval:
// the velocities are free where the tracks ask for it and the line otherwise.
#pragma once

#include <ceres/ceres.h>
#include <ceres/dynamic_autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "core/camera/rolling_shutter.h"
#include "core/sparse/rolling_shutter_reprojection_error.h"
#include "core/sparse/undistorted_reprojection_error.h"

namespace dfsm {

class AngularVelocityReprojectionError {
 public:
  using ReferenceNeighbour = RollingShutterReprojectionError::ReferenceNeighbour;

  // *_rate: s above; height: the frames' rows.
  AngularVelocityReprojectionError(const Eigen::Vector2d& reference_pixel,
                                   const Eigen::Vector2d& observed_pixel, double cx, double cy,
                                   int height, double reference_rate, double frame_rate)
      : reference_(reference_pixel),
        observed_(observed_pixel),
        cx_(cx),
        cy_(cy),
        reference_row_(RowTime(1.0, reference_pixel.y(), height)),
        frame_row_(RowTime(1.0, observed_pixel.y(), height)),
        reference_rate_(reference_rate),
        frame_rate_(frame_rate) {}

  // pose, neighbour, reference_neighbour: {angle-axis (3), T (3)} of the
  // middle rows of frames i, n and m; velocity, reference_velocity: omega_i,
  // omega_ref; the rest as RollingShutterReprojectionError::Evaluate.
  template <typename T>
  bool Evaluate(const T* intrinsics, const T* pose, const T* neighbour,
                const T* reference_neighbour, const T* velocity, const T* reference_velocity,
                const T* inverse_depth, const T* readout, T* residuals) const {
    const T dt_r = readout[0] * reference_row_;
    const T dt_i = readout[0] * frame_row_;
    T reference_row_pose[6], row_pose[6];
    for (int k = 0; k < 3; ++k) {
      reference_row_pose[k] = dt_r * reference_velocity[k];
      reference_row_pose[3 + k] = dt_r * reference_rate_ * reference_neighbour[3 + k];
      row_pose[k] = pose[k] + dt_i * velocity[k];
      row_pose[3 + k] = pose[3 + k] + dt_i * frame_rate_ * (neighbour[3 + k] - pose[3 + k]);
    }
    RowToRowResidual(intrinsics, cx_, cy_, reference_, observed_, inverse_depth[0],
                     reference_row_pose, row_pose, residuals);
    return true;
  }

  // The cost function for the parameter blocks {intrinsics, pose, neighbour,
  // [reference_neighbour,] velocity, reference_velocity, inverse_depth,
  // readout}, the reference neighbour's block only with kOwnBlock,
  // differentiated by Ceres' autodiff: the reference that
  // AngularVelocityCostFunction's hand-written Jacobian (what the adjustment
  // runs) is tested against.
  static ceres::CostFunction* CreateAutoDiff(const AngularVelocityReprojectionError& error,
                                             ReferenceNeighbour shared);

 private:
  friend class AngularVelocityCostFunction;

  Eigen::Vector2d reference_;
  Eigen::Vector2d observed_;
  double cx_, cy_;
  double reference_row_, frame_row_;  // row time per unit readout
  double reference_rate_, frame_rate_;
};

// The functor Ceres differentiates: the blocks in CreateAutoDiff's order,
// the reference's neighbour where `shared` says.
struct AngularVelocityCost {
  static constexpr int kStride = 4;
  AngularVelocityReprojectionError error;
  AngularVelocityReprojectionError::ReferenceNeighbour shared;

  template <typename T>
  bool operator()(T const* const* blocks, T* residuals) const {
    const int next = BlockAfterPoses(shared);
    return error.Evaluate(blocks[0], blocks[1], blocks[2], ReferenceNeighbourBlock(blocks, shared),
                          blocks[next], blocks[next + 1], blocks[next + 2], blocks[next + 3],
                          residuals);
  }
};

inline ceres::CostFunction* AngularVelocityReprojectionError::CreateAutoDiff(
    const AngularVelocityReprojectionError& error, ReferenceNeighbour shared) {
  auto* cost =
      new ceres::DynamicAutoDiffCostFunction<AngularVelocityCost, AngularVelocityCost::kStride>(
          new AngularVelocityCost{error, shared});
  for (const int size : {3, 6, 6}) cost->AddParameterBlock(size);
  if (shared == ReferenceNeighbour::kOwnBlock) cost->AddParameterBlock(6);
  for (const int size : {3, 3, 1, 1}) cost->AddParameterBlock(size);
  cost->SetNumResiduals(2);
  return cost;
}

// (f / sigma) (omega_i - rate (r_a - r_b)): frame i's angular velocity against
// its neighbours' rotation step, a and b the frames after and before it (i
// itself at the burst's ends), rate = 1 / (t_a - t_b). A neighbour that is
// the reference (rotation 0, no block) is left out of the blocks.
struct AngularVelocityPrior {
  double scale;  // f / sigma
  double rate;

  // a's and b's rotation blocks, each null where that neighbour is the reference.
  template <typename T>
  void Residuals(const T* velocity, const T* after, const T* before, T* residuals) const {
    for (int k = 0; k < 3; ++k) {
      const T step = ((after ? after[k] : T(0.0)) - (before ? before[k] : T(0.0))) * rate;
      residuals[k] = scale * (velocity[k] - step);
    }
  }

  // Blocks {velocity, [pose a,] [pose b]}; at least one of a and b is a block.
  static ceres::CostFunction* Create(double scale, double rate, bool after_is_block,
                                     bool before_is_block);
};

// The functors Ceres differentiates: both neighbours blocks, or one of them.
struct AngularVelocityPriorBoth {
  AngularVelocityPrior prior;
  template <typename T>
  bool operator()(const T* velocity, const T* after, const T* before, T* residuals) const {
    prior.Residuals(velocity, after, before, residuals);
    return true;
  }
};
template <bool kAfter>
struct AngularVelocityPriorOne {
  AngularVelocityPrior prior;
  template <typename T>
  bool operator()(const T* velocity, const T* neighbour, T* residuals) const {
    prior.Residuals(velocity, kAfter ? neighbour : nullptr, kAfter ? nullptr : neighbour,
                    residuals);
    return true;
  }
};

inline ceres::CostFunction* AngularVelocityPrior::Create(double scale, double rate,
                                                         bool after_is_block,
                                                         bool before_is_block) {
  const AngularVelocityPrior prior{scale, rate};
  using After = AngularVelocityPriorOne<true>;
  using Before = AngularVelocityPriorOne<false>;
  if (after_is_block && before_is_block)
    return new ceres::AutoDiffCostFunction<AngularVelocityPriorBoth, 3, 3, 6, 6>(
        new AngularVelocityPriorBoth{prior});
  if (after_is_block) return new ceres::AutoDiffCostFunction<After, 3, 3, 6>(new After{prior});
  return new ceres::AutoDiffCostFunction<Before, 3, 3, 6>(new Before{prior});
}

}  // namespace dfsm
