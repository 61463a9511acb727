// The sweep's settings (calibration_sweep.h), without running the sweep (that
// is tests/calibration_sweep_test, label long): the focal range of each field
// of view, lenses the renderer accepts, and the normal sweep's draws.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "tests/support/calibration_sweep.h"

namespace dfsm {
namespace {

double FocalOverLongerSide(const SynthOptions& s) { return s.f / std::max(s.width, s.height); }

TEST(CalibrationSweepSettings, NormalLensesSpanTheirRangeAndKeepTheirK1) {
  const std::vector<SynthOptions> sweep = CalibrationSweepSettings(64, 3);
  ASSERT_EQ(sweep.size(), 64u);
  double lowest_k1 = 1.0, highest_k1 = -1.0;
  for (const SynthOptions& s : sweep) {
    EXPECT_GE(FocalOverLongerSide(s), 0.8);
    EXPECT_LE(FocalOverLongerSide(s), 1.5);
    EXPECT_LE(std::abs(s.k1), 0.3);
    EXPECT_LE(std::abs(s.k2), std::abs(s.k1) / 3.0 + 1e-12);
    EXPECT_LE(s.k1 * s.k2, 0.0);  // opposite signs
    EXPECT_TRUE(RenderedLensIsInvertible(s));
    lowest_k1 = std::min(lowest_k1, s.k1);
    highest_k1 = std::max(highest_k1, s.k1);
  }
  // Barrel and pincushion lenses both, most of the range.
  EXPECT_LT(lowest_k1, -0.2);
  EXPECT_GT(highest_k1, 0.2);
}

TEST(CalibrationSweepSettings, WideLensesShiftTheirCornerAsTheNormalRangesWidest) {
  for (const char* preset : {"ideal", "webcam", "phone"}) {
    const CameraEffects effects = CameraEffects::Preset(preset);
    const std::vector<SynthOptions> wide =
        CalibrationSweepSettings(64, 3, SweepFieldOfView::kWide, effects);
    const std::vector<SynthOptions> normal =
        CalibrationSweepSettings(64, 3, SweepFieldOfView::kNormal, effects);
    for (size_t i = 0; i < wide.size(); ++i) {
      const SynthOptions& s = wide[i];
      EXPECT_GE(FocalOverLongerSide(s), 0.55) << preset << " " << i;
      EXPECT_LE(FocalOverLongerSide(s), 0.8) << preset << " " << i;
      // The corner's radial shift k1 r^2 stays within what k1 0.3 gives at
      // f = 0.8 x the longer side, where r^2 is (1/0.8)^2 x as large.
      const double scale = std::pow(FocalOverLongerSide(s) / 0.8, 2);
      EXPECT_LE(std::abs(s.k1), 0.3 * scale + 1e-12) << preset << " " << i;
      EXPECT_TRUE(RenderedLensIsInvertible(s)) << preset << " " << i;
      EXPECT_EQ(s.effects.k3, effects.k3);
      // Everything but the lens is the normal sweep's.
      EXPECT_EQ(s.width, normal[i].width);
      EXPECT_EQ(s.rotation_deg, normal[i].rotation_deg);
      EXPECT_EQ(s.baseline, normal[i].baseline);
    }
  }
}

TEST(CalibrationSweepSettings, ABarrelLensThatFoldsBeforeTheCornerIsRefused) {
  SynthOptions s;
  s.width = 640;
  s.height = 480;
  s.f = 0.55 * 640;  // 86 deg across
  s.k1 = -0.3;
  s.k2 = 0.0;
  EXPECT_FALSE(RenderedLensIsInvertible(s));
  EXPECT_THROW(SynthesizeBurst(s), std::invalid_argument);
  s.k1 = -0.1;
  EXPECT_TRUE(RenderedLensIsInvertible(s));
}

// The rotation-dominant sweep turns the hand 1-6 deg over 1-10 mm; every
// other draw is the tremor sweep's.
TEST(CalibrationSweepSettings, RotationDominantMotionTurnsMoreOverLess) {
  const CameraEffects effects = CameraEffects::Preset("phone");
  const std::vector<SynthOptions> rotation =
      CalibrationSweepSettings(64, 3, SweepFieldOfView::kNormal, effects, SweepMotion::kRotation);
  const std::vector<SynthOptions> tremor =
      CalibrationSweepSettings(64, 3, SweepFieldOfView::kNormal, effects);
  double smallest = 1.0, largest = 0.0;
  std::set<double> turns;
  for (size_t i = 0; i < rotation.size(); ++i) {
    turns.insert(rotation[i].rotation_deg);
    smallest = std::min(smallest, rotation[i].baseline);
    largest = std::max(largest, rotation[i].baseline);
    EXPECT_EQ(rotation[i].f, tremor[i].f);
    EXPECT_EQ(rotation[i].k1, tremor[i].k1);
    EXPECT_EQ(rotation[i].width, tremor[i].width);
  }
  EXPECT_EQ(turns, (std::set<double>{1.0, 2.0, 4.0, 6.0}));
  EXPECT_GE(smallest, 0.001);
  EXPECT_LT(smallest, 0.002);
  EXPECT_LE(largest, 0.010);
  EXPECT_GT(largest, 0.009);
  EXPECT_EQ(ParseSweepMotion("rotation"), SweepMotion::kRotation);
  EXPECT_THROW(ParseSweepMotion("spin"), std::invalid_argument);
}

TEST(CalibrationSweepSettings, FieldOfViewNamesParse) {
  EXPECT_EQ(ParseSweepFieldOfView("normal"), SweepFieldOfView::kNormal);
  EXPECT_EQ(ParseSweepFieldOfView("wide"), SweepFieldOfView::kWide);
  EXPECT_THROW(ParseSweepFieldOfView("fisheye"), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
