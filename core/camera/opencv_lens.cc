#include "core/camera/opencv_lens.h"

namespace dfsm {

Eigen::Vector2d OpenCvLens::Project(const Eigen::Vector2d& x_u) const {
  double k[8] = {0, 0, 0, 0, 0, 0, 0, 0};  // k1 k2 p1 p2 k3 k4 k5 k6
  for (size_t i = 0; i < distortion.size() && i < 8; ++i) k[i] = distortion[i];
  const double x = x_u.x(), y = x_u.y();
  const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double radial =
      (1.0 + k[0] * r2 + k[1] * r4 + k[4] * r6) / (1.0 + k[5] * r2 + k[6] * r4 + k[7] * r6);
  const double x_d = x * radial + 2.0 * k[2] * x * y + k[3] * (r2 + 2.0 * x * x);
  const double y_d = y * radial + k[2] * (r2 + 2.0 * y * y) + 2.0 * k[3] * x * y;
  return {fx * x_d + cx, fy * y_d + cy};
}

}  // namespace dfsm
