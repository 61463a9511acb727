// UndistortedReprojectionError for a rolling shutter (Im et al., ICCV 2015, in
// small motion; core/camera/rolling_shutter.h). The reference observation of
// track j was exposed at row time dt_r, its observation in frame i at dt_i
// (readout * ((v + 0.5) / h - 0.5), v the observed row), each from the pose
// of its own row, on the line through its frame's pose and a neighbour's:
//
//     P_ref(dt_r) = dt_r * s_r * P_m,         (the reference's pose is 0)
//     P_i(dt_i)   = P_i + dt_i * s_i * (P_n - P_i),
//
// where n is the neighbour of frame i on the side of dt_i (the other side at
// the burst's ends), m the reference's, and s = 1 / (t_n - t_i) the rate of
// the neighbour's side (NeighbourOnSide: +1 for the next of consecutive
// frames, -1 for the previous). The neighbours' poses are parameters too, so the steps
// move with the poses. The ray p_j at inverse depth w_j in the reference
// row's camera is, scaled by w_j,
//
//     w X = R_ref(dt_r)^T (p_j - w T_ref(dt_r))      (reference frame, middle row),
//     X_i ∝ R_i(dt_i) (w X) + w T_i(dt_i),
//
// and the readout is a parameter, so the adjustment can estimate it. With
// readout 0 it is UndistortedReprojectionError. The neighbours are chosen by
// the rows' side of the middle for a positive readout; a negative one (read
// bottom-up) extrapolates the other neighbour's segment, equal to first order
// for a smooth path.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "core/camera/camera_model.h"
#include "core/camera/rolling_shutter.h"
#include "core/sparse/undistorted_reprojection_error.h"

namespace dfsm {

// The residual of a track observed from row pose `row_pose` of frame i, its
// reference pixel undistorted to the ray p at inverse depth w in the camera of
// the reference row, whose pose is `reference_row_pose` (both {angle-axis
// (3), T (3)} against the reference frame's middle row):
//
//     w X = R_ref^T (p - w T_ref),     X_i ∝ R_i (w X) + w T_i.
template <typename T>
void RowToRowResidual(const T* intrinsics, double cx, double cy, const Eigen::Vector2d& reference,
                      const Eigen::Vector2d& observed, const T& w, const T* reference_row_pose,
                      const T* row_pose, T* residuals) {
  T p[3];
  PixelToUndistorted(intrinsics[0], intrinsics[1], intrinsics[2], cx, cy, reference.x(),
                     reference.y(), &p[0], &p[1]);
  p[2] = T(1.0);
  T minus_rotation[3], shifted[3];
  for (int k = 0; k < 3; ++k) {
    minus_rotation[k] = -reference_row_pose[k];
    shifted[k] = p[k] - w * reference_row_pose[3 + k];
  }
  T wX[3];
  ceres::AngleAxisRotatePoint(minus_rotation, shifted, wX);
  T X[3];
  ceres::AngleAxisRotatePoint(row_pose, wX, X);
  for (int k = 0; k < 3; ++k) X[k] += w * row_pose[3 + k];
  UndistortedResidual(intrinsics, cx, cy, observed, X, residuals);
}

class RollingShutterReprojectionError {
 public:
  // Which pose parameter block holds the reference's neighbour m: a block of
  // its own, frame i's, or frame i's neighbour's (Ceres takes a block once).
  enum class ReferenceNeighbour { kOwnBlock, kFrame, kFrameNeighbour };

  // *_rate: s above; height: the frames' rows.
  RollingShutterReprojectionError(const Eigen::Vector2d& reference_pixel,
                                  const Eigen::Vector2d& observed_pixel, double cx, double cy,
                                  int height, double reference_rate, double frame_rate)
      : reference_(reference_pixel),
        observed_(observed_pixel),
        cx_(cx),
        cy_(cy),
        reference_row_(RowTime(1.0, reference_pixel.y(), height) * reference_rate),
        frame_row_(RowTime(1.0, observed_pixel.y(), height) * frame_rate) {}

  // intrinsics = {f, k1, k2}; pose, neighbour, reference_neighbour = {angle-axis
  // (3), T (3)} of the middle rows of frames i, n and m; inverse_depth = {w_j};
  // readout = {fraction of the frame interval}.
  template <typename T>
  bool Evaluate(const T* intrinsics, const T* pose, const T* neighbour,
                const T* reference_neighbour, const T* inverse_depth, const T* readout,
                T* residuals) const {
    // The reference row's pose and the observed row's, on their lines.
    const T a_r = readout[0] * reference_row_;
    const T a_i = readout[0] * frame_row_;
    T reference_row_pose[6], row_pose[6];
    for (int k = 0; k < 6; ++k) {
      reference_row_pose[k] = a_r * reference_neighbour[k];
      row_pose[k] = pose[k] + a_i * (neighbour[k] - pose[k]);
    }
    RowToRowResidual(intrinsics, cx_, cy_, reference_, observed_, inverse_depth[0],
                     reference_row_pose, row_pose, residuals);
    return true;
  }

  // The cost function for the parameter blocks {intrinsics, pose, neighbour,
  // [reference_neighbour,] inverse_depth, readout}, the reference neighbour's
  // block only with kOwnBlock, differentiated by Ceres' autodiff: the
  // reference that RollingShutterCostFunction's hand-written Jacobian (what
  // the adjustment runs) is tested against.
  static ceres::CostFunction* CreateAutoDiff(const RollingShutterReprojectionError& error,
                                             ReferenceNeighbour shared);

 private:
  friend class RollingShutterCostFunction;

  Eigen::Vector2d reference_;
  Eigen::Vector2d observed_;
  double cx_, cy_;
  double reference_row_, frame_row_;  // row time per unit readout, times the side's rate
};

// The blocks both row models' cost functions begin with: {intrinsics, pose,
// neighbour, [reference_neighbour]}, the last only with kOwnBlock. The
// reference's neighbour m among them, and the index of the block after them.
template <typename T>
const T* ReferenceNeighbourBlock(T const* const* blocks,
                                 RollingShutterReprojectionError::ReferenceNeighbour shared) {
  using Shared = RollingShutterReprojectionError::ReferenceNeighbour;
  return shared == Shared::kFrame            ? blocks[1]
         : shared == Shared::kFrameNeighbour ? blocks[2]
                                             : blocks[3];
}
inline int BlockAfterPoses(RollingShutterReprojectionError::ReferenceNeighbour shared) {
  return shared == RollingShutterReprojectionError::ReferenceNeighbour::kOwnBlock ? 4 : 3;
}

// The functors Ceres differentiates: the reference's neighbour in a block of
// its own, or shared with frame i's pose (kFrame) or its neighbour's.
struct RollingShutterOwnBlock {
  RollingShutterReprojectionError error;
  template <typename T>
  bool operator()(const T* intrinsics, const T* pose, const T* neighbour,
                  const T* reference_neighbour, const T* inverse_depth, const T* readout,
                  T* residuals) const {
    return error.Evaluate(intrinsics, pose, neighbour, reference_neighbour, inverse_depth, readout,
                          residuals);
  }
};
template <RollingShutterReprojectionError::ReferenceNeighbour kShared>
struct RollingShutterSharedBlock {
  RollingShutterReprojectionError error;
  template <typename T>
  bool operator()(const T* intrinsics, const T* pose, const T* neighbour, const T* inverse_depth,
                  const T* readout, T* residuals) const {
    constexpr bool kFrame = kShared == RollingShutterReprojectionError::ReferenceNeighbour::kFrame;
    return error.Evaluate(intrinsics, pose, neighbour, kFrame ? pose : neighbour, inverse_depth,
                          readout, residuals);
  }
};

inline ceres::CostFunction* RollingShutterReprojectionError::CreateAutoDiff(
    const RollingShutterReprojectionError& error, ReferenceNeighbour shared) {
  using Frame = RollingShutterSharedBlock<ReferenceNeighbour::kFrame>;
  using FrameNeighbour = RollingShutterSharedBlock<ReferenceNeighbour::kFrameNeighbour>;
  switch (shared) {
    case ReferenceNeighbour::kFrame:
      return new ceres::AutoDiffCostFunction<Frame, 2, 3, 6, 6, 1, 1>(new Frame{error});
    case ReferenceNeighbour::kFrameNeighbour:
      return new ceres::AutoDiffCostFunction<FrameNeighbour, 2, 3, 6, 6, 1, 1>(
          new FrameNeighbour{error});
    case ReferenceNeighbour::kOwnBlock:
      break;
  }
  return new ceres::AutoDiffCostFunction<RollingShutterOwnBlock, 2, 3, 6, 6, 6, 1, 1>(
      new RollingShutterOwnBlock{error});
}

}  // namespace dfsm
