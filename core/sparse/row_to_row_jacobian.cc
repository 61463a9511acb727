#include "core/sparse/row_to_row_jacobian.h"

#include <cmath>

#include "core/camera/camera_model.h"

namespace dfsm {
namespace {

using Vector2 = Eigen::Vector2d;
using Vector3 = Eigen::Vector3d;
using Matrix3 = Eigen::Matrix3d;
using Matrix23 = Eigen::Matrix<double, 2, 3>;

Matrix3 Hat(const Vector3& v) {
  Matrix3 hat;
  hat << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return hat;
}

// R(phi) = exp([phi]_x) and the right Jacobian J_r(phi) of SO(3), from the
// Rodrigues coefficients a = sin t / t, b = (1 - cos t) / t^2 and
// c = (t - sin t) / t^3 (t = |phi|):
//
//     R = I + a [phi]_x + b [phi]_x^2,     J_r = I - b [phi]_x + c [phi]_x^2.
//
// Below t = 0.01 the closed forms lose digits to cancellation (c most), so
// their Taylor series take over; the first term left out is under 1e-16.
struct Rotation {
  Matrix3 R, right_jacobian;

  explicit Rotation(const Vector3& phi) {
    const double t2 = phi.squaredNorm();
    double a, b, c;
    if (t2 < 1e-4) {
      a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0);
      b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0);
      c = 1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0);
    } else {
      const double t = std::sqrt(t2);
      a = std::sin(t) / t;
      b = (1.0 - std::cos(t)) / t2;
      c = (t - std::sin(t)) / (t2 * t);
    }
    const Matrix3 K = Hat(phi);
    const Matrix3 K2 = K * K;
    R = Matrix3::Identity() + a * K + b * K2;
    right_jacobian = Matrix3::Identity() - b * K + c * K2;
  }
};

// PixelToUndistorted and, when `jacobian` is given, its derivative by
// (f, k1, k2): with d = (u - c) / f, r2 = |d|^2 and F = 1 + k1 r2 + k2 r2^2,
// p = F d, so dp/df = -(F + 2 r2 dF/dr2) d / f, dp/dk1 = r2 d, dp/dk2 = r2^2 d.
Vector2 Undistort(const double* intrinsics, double cx, double cy, const Vector2& pixel,
                  Matrix23* jacobian) {
  const double f = intrinsics[0], k1 = intrinsics[1], k2 = intrinsics[2];
  const Vector2 d((pixel.x() - cx) / f, (pixel.y() - cy) / f);
  const double r2 = d.squaredNorm();
  const double factor = RadialFactor(k1, k2, r2);
  if (jacobian) {
    jacobian->col(0) = -(factor + 2.0 * r2 * (k1 + 2.0 * k2 * r2)) / f * d;
    jacobian->col(1) = r2 * d;
    jacobian->col(2) = r2 * r2 * d;
  }
  return factor * d;
}

}  // namespace

Eigen::Vector2d DifferentiateRowToRow(const double* intrinsics, double cx, double cy,
                                      const Eigen::Vector2d& reference,
                                      const Eigen::Vector2d& observed, double w,
                                      const RowPoseVector& reference_row_pose,
                                      const RowPoseVector& row_pose,
                                      RowToRowDerivatives* derivatives) {
  const double f = intrinsics[0];
  Matrix23 dp_dintrinsics, do_dintrinsics;
  const Vector2 p =
      Undistort(intrinsics, cx, cy, reference, derivatives ? &dp_dintrinsics : nullptr);
  const Vector2 o =
      Undistort(intrinsics, cx, cy, observed, derivatives ? &do_dintrinsics : nullptr);
  // The reference row's camera back to the reference frame's middle row.
  const Rotation back(-reference_row_pose.head<3>());
  const Vector3 reference_T = reference_row_pose.tail<3>();
  const Vector3 s = Vector3(p.x(), p.y(), 1.0) - w * reference_T;
  const Vector3 wX = back.R * s;
  // Into the camera of the observed row.
  const Rotation row(row_pose.head<3>());
  const Vector3 X = row.R * wX + w * row_pose.tail<3>();
  const Vector2 projection = X.head<2>() / X.z();
  const Vector2 residual = f * (projection - o);
  if (!derivatives) return residual;

  Matrix23 dr_dX;
  dr_dX << 1.0, 0.0, -projection.x(), 0.0, 1.0, -projection.y();
  dr_dX *= f / X.z();
  const Matrix23 dr_dwX = dr_dX * row.R;
  const Matrix23 dr_ds = dr_dwX * back.R;
  // phi_ref enters as R(-phi_ref): the sign of d R(phi) s / d phi turns.
  derivatives->reference_row_pose << dr_ds * Hat(s) * back.right_jacobian, -w * dr_ds;
  derivatives->row_pose << -dr_dwX * Hat(wX) * row.right_jacobian, w * dr_dX;
  derivatives->inverse_depth = dr_dX * row_pose.tail<3>() - dr_ds * reference_T;
  derivatives->intrinsics = dr_ds.leftCols<2>() * dp_dintrinsics - f * do_dintrinsics;
  derivatives->intrinsics.col(0) += projection - o;
  return residual;
}

std::vector<int32_t> IntrinsicsAndPoseBlockSizes(
    RollingShutterReprojectionError::ReferenceNeighbour shared) {
  std::vector<int32_t> sizes = {3, 6, 6};
  if (shared == RollingShutterReprojectionError::ReferenceNeighbour::kOwnBlock) sizes.push_back(6);
  return sizes;
}

void StoreIntrinsicsAndPoseJacobians(RollingShutterReprojectionError::ReferenceNeighbour shared,
                                     const Eigen::Matrix<double, 2, 3>& dr_dintrinsics,
                                     Eigen::Matrix<double, 2, 6> dr_dpose,
                                     Eigen::Matrix<double, 2, 6> dr_dneighbour,
                                     const Eigen::Matrix<double, 2, 6>& dr_dreference_neighbour,
                                     double** jacobians) {
  using Shared = RollingShutterReprojectionError::ReferenceNeighbour;
  if (shared == Shared::kFrame) dr_dpose += dr_dreference_neighbour;
  if (shared == Shared::kFrameNeighbour) dr_dneighbour += dr_dreference_neighbour;
  StoreJacobianBlock<3>(dr_dintrinsics, jacobians[0]);
  StoreJacobianBlock<6>(dr_dpose, jacobians[1]);
  StoreJacobianBlock<6>(dr_dneighbour, jacobians[2]);
  if (shared == Shared::kOwnBlock) StoreJacobianBlock<6>(dr_dreference_neighbour, jacobians[3]);
}

}  // namespace dfsm
