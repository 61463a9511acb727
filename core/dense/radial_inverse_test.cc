#include "core/dense/radial_inverse.h"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>
#include <tuple>

namespace dfsm {
namespace {

CameraModel Camera(int width, int height, double f, double k1, double k2) {
  CameraModel camera;
  camera.width = width;
  camera.height = height;
  camera.f = f;
  camera.cx = width / 2.0;
  camera.cy = height / 2.0;
  camera.k1 = k1;
  camera.k2 = k2;
  return camera;
}

CameraModel Camera(double k1, double k2) { return Camera(1920, 1080, 2112.0, k1, k2); }

// The largest distance (pixels) between a pixel and where the fitted inverse
// sends its undistorted point, over a grid of `step_v` x `step_u` pixels.
double WorstRoundTripPx(const CameraModel& camera, const RadialInverse& inverse, int step_v,
                        int step_u) {
  double worst = 0.0;
  for (int v = 0; v < camera.height; v += step_v) {
    for (int u = 0; u < camera.width; u += step_u) {
      const Eigen::Vector2d x_u = camera.PixelToUndistorted({u, v});
      const float ratio = inverse.Ratio(static_cast<float>(x_u.squaredNorm()));
      const Eigen::Vector2d pixel(camera.cx + camera.f * ratio * x_u.x(),
                                  camera.cy + camera.f * ratio * x_u.y());
      worst = std::max(worst, (pixel - Eigen::Vector2d(u, v)).norm());
    }
  }
  return worst;
}

// The fitted inverse lands every pixel back where CameraModel's Newton
// inverse does, across the whole image, for barrel and pincushion models.
TEST(RadialInverseTest, AgreesWithNewtonInverseOverTheImage) {
  for (const auto& [k1, k2] : {std::pair{-0.06, 0.015}, std::pair{0.1, -0.02},
                               std::pair{-0.25, 0.08}, std::pair{0.0, 0.0}}) {
    const CameraModel camera = Camera(k1, k2);
    const RadialInverse inverse(camera);
    EXPECT_LT(inverse.fit_error(), 1e-6);
    EXPECT_LT(WorstRoundTripPx(camera, inverse, 27, 31), 0.01) << "k1 " << k1 << " k2 " << k2;
  }
}

// Wide-angle cameras (640x480, f 362-380, k2 negative: standing in for a
// third radial term) whose inverse no polynomial of degree <= 10 follows to
// 1e-6 of the radius: the best one lands every pixel within the sweep's own
// precision, so the camera is used (it used to be refused and replaced by one
// without distortion). The cameras the adjustment estimated on generated
// f 400 bursts when this was written now meet 1e-6 over the image's own range
// (TakesALensThatFoldsJustBeyondTheImage).
TEST(RadialInverseTest, TakesAWideAngleLensAtThePixelTolerance) {
  for (const auto& [f, k1, k2] :
       {std::tuple{362.5, -0.0362, -0.05}, std::tuple{380.0, -0.0362, -0.06}}) {
    const CameraModel camera = Camera(640, 480, f, k1, k2);
    const RadialInverse inverse(camera);
    EXPECT_GT(inverse.fit_error(), 1e-6) << "not a case the strict bound takes";
    EXPECT_LT(WorstRoundTripPx(camera, inverse, 7, 9), 0.01)
        << "f " << f << " k1 " << k1 << " k2 " << k2;
  }
}

// Cameras whose radial map folds just beyond the image's corners: the
// adjustment's estimates on generated wide-angle phone bursts (640x480; f 420
// with k1 -0.1 and 0.1 seeds 11 and 13, f 400 seed 3). Their inverse grows
// like a square root toward the fold, and a fit that reached 10 % past the
// corners could not follow it (the third at 0.0099 px, the others 0.1-0.3 px
// where the bound is 0.01), so the pipeline refused them although they fit
// their bursts: their f errors 0.1, 5.7 and 1.8 %, the k1-only refits' 7.1,
// 15.0 and 12.0 %.
TEST(RadialInverseTest, TakesALensThatFoldsJustBeyondTheImage) {
  for (const auto& [width, height, f, k1, k2] :
       {std::tuple{640, 480, 419.62, -0.059473, -0.079482},
        std::tuple{640, 480, 444.1, -0.0897, -0.0921},
        std::tuple{640, 480, 406.995, -0.0294446, -0.0690392},
        // 1920x1080 (f 0.6 x the width, 1 deg, the wide depth sweep's burst
        // 43): even over the image's own range, the least-squares fit misses
        // by 0.012 px at the corners, the minimax one by 0.004 px. Refused,
        // the k1-only refit's f was 6.5 % off and its depth 10 % (confirmed).
        std::tuple{1920, 1080, 1167.4, -0.119167, -0.054776}}) {
    const CameraModel camera = Camera(width, height, f, k1, k2);
    const RadialInverse inverse(camera);
    EXPECT_LT(WorstRoundTripPx(camera, inverse, 7, 9), 0.01)
        << "f " << f << " k1 " << k1 << " k2 " << k2;
    // The corners themselves, where the inverse is hardest to fit.
    EXPECT_LT(WorstRoundTripPx(camera, inverse, camera.height - 1, camera.width - 1), 0.01);
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
