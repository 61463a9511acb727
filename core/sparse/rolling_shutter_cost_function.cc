#include "core/sparse/rolling_shutter_cost_function.h"

#include <Eigen/Core>
#include <cmath>

#include "core/camera/camera_model.h"

namespace dfsm {
namespace {

using Vector2 = Eigen::Vector2d;
using Vector3 = Eigen::Vector3d;
using Matrix3 = Eigen::Matrix3d;
using Matrix23 = Eigen::Matrix<double, 2, 3>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

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

template <int kColumns>
void Store(const Eigen::Matrix<double, 2, kColumns>& jacobian, double* block) {
  // Ceres' Jacobian blocks are row-major.
  using RowMajor = Eigen::Matrix<double, 2, kColumns, kColumns == 1 ? 0 : Eigen::RowMajor>;
  if (block) Eigen::Map<RowMajor>{block} = jacobian;
}

}  // namespace

RollingShutterCostFunction::RollingShutterCostFunction(const RollingShutterReprojectionError& error,
                                                       ReferenceNeighbour shared)
    : error_(error), shared_(shared) {
  set_num_residuals(2);
  std::vector<int32_t>& sizes = *mutable_parameter_block_sizes();
  sizes = {3, 6, 6};
  if (shared == ReferenceNeighbour::kOwnBlock) sizes.push_back(6);
  sizes.push_back(1);
  sizes.push_back(1);
}

bool RollingShutterCostFunction::Evaluate(double const* const* parameters, double* residuals,
                                          double** jacobians) const {
  const bool own = shared_ == ReferenceNeighbour::kOwnBlock;
  const double* intrinsics = parameters[0];
  const Eigen::Map<const Vector6> pose(parameters[1]);
  const Eigen::Map<const Vector6> neighbour(parameters[2]);
  const Eigen::Map<const Vector6> reference_neighbour(own ? parameters[3]
                                                      : shared_ == ReferenceNeighbour::kFrame
                                                          ? parameters[1]
                                                          : parameters[2]);
  const double w = parameters[own ? 4 : 3][0];
  const double readout = parameters[own ? 5 : 4][0];
  const double f = intrinsics[0];

  Matrix23 dp_dintrinsics, do_dintrinsics;
  const Vector2 p = Undistort(intrinsics, error_.cx_, error_.cy_, error_.reference_,
                              jacobians ? &dp_dintrinsics : nullptr);
  const Vector2 observed = Undistort(intrinsics, error_.cx_, error_.cy_, error_.observed_,
                                     jacobians ? &do_dintrinsics : nullptr);
  // The reference row's camera back to the reference frame's middle row.
  const double a_r = readout * error_.reference_row_;
  const Vector3 m_omega = reference_neighbour.head<3>(), m_T = reference_neighbour.tail<3>();
  const Rotation reference_row(-a_r * m_omega);
  const Vector3 s = Vector3(p.x(), p.y(), 1.0) - w * a_r * m_T;
  const Vector3 wX = reference_row.R * s;
  // Into the camera of the observed row of frame i.
  const double a_i = readout * error_.frame_row_;
  const Vector6 row_pose = pose + a_i * (neighbour - pose);
  const Rotation frame_row(row_pose.head<3>());
  const Vector3 X = frame_row.R * wX + w * row_pose.tail<3>();
  const Vector2 projection = X.head<2>() / X.z();
  Eigen::Map<Vector2>{residuals} = f * (projection - observed);
  if (!jacobians) return true;

  // dr/dX, then the derivatives of wX and X by their inputs.
  Matrix23 dr_dX;
  dr_dX << 1.0, 0.0, -projection.x(), 0.0, 1.0, -projection.y();
  dr_dX *= f / X.z();
  const Matrix23 dr_dwX = dr_dX * frame_row.R;
  const Matrix3 dwX_dphi = -reference_row.R * Hat(s) * reference_row.right_jacobian;
  const Matrix3 dX_dQomega = -frame_row.R * Hat(wX) * frame_row.right_jacobian;
  const Matrix23 dr_dQomega = dr_dX * dX_dQomega;
  const Matrix23 dr_dQT = w * dr_dX;

  Matrix23 dr_dintrinsics = dr_dwX * reference_row.R.leftCols<2>() * dp_dintrinsics;
  dr_dintrinsics.col(0) += projection - observed;
  dr_dintrinsics -= f * do_dintrinsics;

  Eigen::Matrix<double, 2, 6> dr_dpose, dr_dneighbour, dr_dreference_neighbour;
  dr_dpose << (1.0 - a_i) * dr_dQomega, (1.0 - a_i) * dr_dQT;
  dr_dneighbour << a_i * dr_dQomega, a_i * dr_dQT;
  dr_dreference_neighbour << -a_r * dr_dwX * dwX_dphi, -w * a_r * dr_dwX * reference_row.R;

  const Vector2 dr_dw = dr_dX * row_pose.tail<3>() - a_r * dr_dwX * reference_row.R * m_T;
  const Vector3 dwX_dreadout =
      -error_.reference_row_ * (dwX_dphi * m_omega + w * reference_row.R * m_T);
  const Vector6 step = neighbour - pose;
  const Vector2 dr_dreadout =
      error_.frame_row_ * (dr_dQomega * step.head<3>() + dr_dQT * step.tail<3>()) +
      dr_dwX * dwX_dreadout;

  // A block shared by two roles takes both derivatives.
  if (shared_ == ReferenceNeighbour::kFrame) dr_dpose += dr_dreference_neighbour;
  if (shared_ == ReferenceNeighbour::kFrameNeighbour) dr_dneighbour += dr_dreference_neighbour;
  Store<3>(dr_dintrinsics, jacobians[0]);
  Store<6>(dr_dpose, jacobians[1]);
  Store<6>(dr_dneighbour, jacobians[2]);
  if (own) Store<6>(dr_dreference_neighbour, jacobians[3]);
  Store<1>(dr_dw, jacobians[own ? 4 : 3]);
  Store<1>(dr_dreadout, jacobians[own ? 5 : 4]);
  return true;
}

}  // namespace dfsm
