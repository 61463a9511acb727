#include "core/dense/radial_inverse.h"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

namespace dfsm {
namespace {

CameraModel Camera(double k1, double k2) {
  CameraModel camera;
  camera.width = 1920;
  camera.height = 1080;
  camera.f = 2112.0;
  camera.cx = 960.0;
  camera.cy = 540.0;
  camera.k1 = k1;
  camera.k2 = k2;
  return camera;
}

// The fitted inverse lands every pixel back where CameraModel's Newton
// inverse does, across the whole image, for barrel and pincushion models.
TEST(RadialInverseTest, AgreesWithNewtonInverseOverTheImage) {
  for (const auto& [k1, k2] : {std::pair{-0.06, 0.015}, std::pair{0.1, -0.02},
                               std::pair{-0.25, 0.08}, std::pair{0.0, 0.0}}) {
    const CameraModel camera = Camera(k1, k2);
    const RadialInverse inverse(camera);
    EXPECT_LT(inverse.fit_error(), 1e-6);
    double worst = 0.0;
    for (int v = 0; v < camera.height; v += 27) {
      for (int u = 0; u < camera.width; u += 31) {
        const Eigen::Vector2d x_u = camera.PixelToUndistorted({u, v});
        const float ratio = inverse.Ratio(static_cast<float>(x_u.squaredNorm()));
        const Eigen::Vector2d pixel(camera.cx + camera.f * ratio * x_u.x(),
                                    camera.cy + camera.f * ratio * x_u.y());
        worst = std::max(worst, (pixel - Eigen::Vector2d(u, v)).norm());
      }
    }
    EXPECT_LT(worst, 0.01) << "k1 " << k1 << " k2 " << k2;
  }
}

TEST(RadialInverseTest, RejectsAModelThatFoldsInsideTheImage) {
  try {
    RadialInverse inverse(Camera(-3.0, 0.0));
    FAIL() << "a folding model was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not invertible"), std::string::npos) << e.what();
  }
  EXPECT_THROW(RadialInverse(Camera(0.0, std::numeric_limits<double>::quiet_NaN())),
               std::invalid_argument);
  CameraModel no_focal = Camera(0.0, 0.0);
  no_focal.f = 0.0;
  EXPECT_THROW(RadialInverse{no_focal}, std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
