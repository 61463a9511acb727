#include "core/sparse/camera_relief_disagreement.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace dfsm {
namespace {

// A common scale is free: the same relief at another scale does not
// disagree at all.
TEST(CameraReliefDisagreement, AScaleIsNotRelief) {
  const std::vector<double> w = {0.5, 0.8, 1.0, 1.3, 2.0};
  const std::vector<bool> all(w.size(), true);
  std::vector<double> scaled;
  for (double v : w) scaled.push_back(3.0 * v);
  EXPECT_NEAR(CameraReliefDisagreement(w, all, scaled, all), 0.0, 1e-12);
}

// An inverse-depth offset b (the small motion's weak direction) moves each
// track by b / w relative to the common scale: the median of those after the
// median ratio is taken out.
TEST(CameraReliefDisagreement, AnOffsetIsMeasuredAfterTheCommonScale) {
  const std::vector<double> w = {0.5, 1.0, 2.0};
  const std::vector<double> shifted = {0.6, 1.1, 2.1};  // b = 0.1
  const std::vector<bool> all(3, true);
  // Ratios 1.2, 1.1, 1.05; median 1.1; |r / 1.1 - 1|: 0.0909, 0, 0.0455.
  EXPECT_NEAR(CameraReliefDisagreement(w, all, shifted, all), 0.05 / 1.1, 1e-12);
}

// Only the tracks both solutions keep, on the same side of the camera in
// both, compare; fewer than two: not measured.
TEST(CameraReliefDisagreement, ComparesOnlyTheTracksBothKeep) {
  const std::vector<double> a = {1.0, 1.0, 1.0, 1.0};
  const std::vector<double> b = {1.0, 1.0, 5.0, -1.0};
  EXPECT_NEAR(CameraReliefDisagreement(a, {true, true, true, true}, b, {true, true, false, true}),
              0.0, 1e-12);
  EXPECT_DOUBLE_EQ(
      CameraReliefDisagreement(a, {true, false, true, true}, b, {true, true, false, true}), -1.0);
  EXPECT_THROW(CameraReliefDisagreement(a, {true}, b, {true, true, true, true}),
               std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
