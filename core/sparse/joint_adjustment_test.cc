#include "core/sparse/joint_adjustment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "tests/support/track_simulator.h"

namespace dfsm {
namespace {

// A global shutter, as simulated.
SparseOptions GlobalShutterSparse() {
  SparseOptions options;
  options.rolling_shutter.mode = RollingShutterOptions::Mode::kGlobal;
  return options;
}

// Bursts of one 640x480 camera (f `f`), seeds from `first_seed`, each through
// the whole sparse stage alone under `options`; their simulations in `sims`.
std::vector<JointBurst> BurstsOfOneCamera(double f, double k1, int count, uint64_t first_seed,
                                          double rotation_deg, double noise_px,
                                          std::vector<SparseReconstruction>* alone = nullptr,
                                          const SparseOptions& options = GlobalShutterSparse(),
                                          std::vector<TrackSimulation>* sims = nullptr) {
  std::vector<JointBurst> bursts;
  for (int b = 0; b < count; ++b) {
    TrackSimulatorOptions simulate;
    simulate.width = 640;
    simulate.height = 480;
    simulate.tracks = 150;
    simulate.f = f;
    simulate.k1 = k1;
    simulate.rotation_deg = rotation_deg;
    simulate.noise_px = noise_px;
    simulate.seed = first_seed + b;
    const TrackSimulation sim = SimulateTracks(simulate);
    const SparseReconstruction sparse = ReconstructFromTracks(sim.tracks, 640, 480, options);
    if (alone) alone->push_back(sparse);
    if (sims) sims->push_back(sim);
    bursts.push_back(JointBurstOf("burst " + std::to_string(first_seed + b), sparse));
  }
  return bursts;
}

JointAdjustmentOptions GlobalShutter() { return JointOptionsFor(GlobalShutterSparse()); }

double SigmaF(const CalibrationUncertainty& uncertainty, const CameraModel& camera) {
  return uncertainty.available ? uncertainty.sigma_f_percent(camera.f) : 100.0;
}

// Bursts too weak to calibrate the camera alone (a degree of tremor, 0.1 px
// of tracking noise at VGA: most are degenerate, sigma_f 6-11 %) share it in
// one problem: the joint camera is within its 2 sigma of the truth, and
// that sigma is below every burst's own.
TEST(JointAdjustment, RecoversTheCameraOfBurstsTooWeakAlone) {
  std::vector<SparseReconstruction> alone;
  const std::vector<JointBurst> bursts = BurstsOfOneCamera(704.0, -0.06, 5, 1, 1.0, 0.1, &alone);
  int degenerate = 0;
  double smallest_sigma = 100.0;
  for (const SparseReconstruction& sparse : alone) {
    degenerate += sparse.verdict.quality == CalibrationQuality::kDegenerate;
    smallest_sigma = std::min(smallest_sigma, SigmaF(sparse.uncertainty, sparse.state.camera));
  }
  EXPECT_GE(degenerate, 3);
  const JointCalibration joint = AdjustJointly(bursts, GlobalShutter());
  EXPECT_EQ(joint.Joined(), 5);
  const double sigma = SigmaF(joint.uncertainty, joint.camera);
  EXPECT_LT(sigma, smallest_sigma);
  EXPECT_LE(std::abs(joint.camera.f - 704.0), 2.0 * sigma / 100.0 * joint.camera.f)
      << "joint f " << joint.camera.f << ", sigma " << sigma << " %";
  EXPECT_NE(joint.verdict.quality, CalibrationQuality::kDegenerate);
  // The bias the tracks' noise gave the fit was measured and taken off.
  ASSERT_TRUE(joint.bias.has_value());
  EXPECT_TRUE(joint.bias->usable);
  EXPECT_GT(joint.fitted_camera.f, joint.camera.f);
  for (const JointBurstResult& burst : joint.bursts) EXPECT_EQ(burst.poses.size(), 10u);
}

// Bursts of another camera of the same size (f 560 against 704) are found
// and left out, not averaged in: the shared camera is the majority's.
TEST(JointAdjustment, LeavesOutTheBurstsOfAnotherCamera) {
  std::vector<JointBurst> bursts = BurstsOfOneCamera(704.0, -0.06, 4, 11, 1.0, 0.05);
  for (JointBurst& other : BurstsOfOneCamera(560.0, -0.12, 2, 21, 1.0, 0.05))
    bursts.push_back(std::move(other));
  const JointCalibration joint = AdjustJointly(bursts, GlobalShutter());
  for (int b = 0; b < 6; ++b)
    EXPECT_EQ(joint.bursts[b].outcome, b < 4 ? JointOutcome::kJoined : JointOutcome::kDisagrees)
        << "burst " << b << ", disagreement " << joint.bursts[b].disagreement;
  const double sigma = SigmaF(joint.uncertainty, joint.camera);
  EXPECT_LE(std::abs(joint.camera.f - 704.0), 2.0 * sigma / 100.0 * joint.camera.f)
      << "joint f " << joint.camera.f << ", sigma " << sigma << " %";
  // The camera's own bursts scatter as their noise says: no dispersion.
  EXPECT_EQ(joint.dispersion, 1.0);
  ASSERT_FALSE(joint.verdict.reasons.empty());
  EXPECT_NE(joint.verdict.reasons.back().find("2 of 6 bursts disagree"), std::string::npos)
      << joint.verdict.reasons.back();
}

// A burst's disagreement is the rise of its cost from its own minimum of the
// joint problem's cost, wherever its own camera was found: one burst's camera
// moved off that minimum (as a stage that refined it under another row model
// leaves it) still rises to the joint camera, never falls.
TEST(JointAdjustment, ADisagreementRisesFromTheBurstsOwnMinimum) {
  std::vector<JointBurst> bursts = BurstsOfOneCamera(704.0, -0.06, 5, 31, 1.0, 0.05);
  bursts[2].state.camera.f *= 1.05;
  const JointCalibration joint = AdjustJointly(bursts, GlobalShutter());
  for (size_t b = 0; b < bursts.size(); ++b)
    EXPECT_GE(joint.bursts[b].disagreement, -1e-3) << "burst " << b;
  EXPECT_EQ(joint.Joined(), 5);
}

// The shared f's sigma takes how far the bursts' own focal lengths scatter
// against their own sigma_f, and k1's and k2's do not: the same bursts
// claiming a tenth of their sigma_f scatter a hundred times more than they
// say, which widens f's sigma alone, by the square root of the focal
// dispersion; the camera itself does not move.
TEST(JointAdjustment, TheFocalLengthsOwnScatterWidensTheSharedFsSigmaAlone) {
  const std::vector<JointBurst> bursts = BurstsOfOneCamera(704.0, -0.06, 5, 1, 1.0, 0.1);
  std::vector<JointBurst> overconfident = bursts;
  for (JointBurst& burst : overconfident) burst.sigma_f_percent /= 10.0;
  const JointCalibration joint = AdjustJointly(bursts, GlobalShutter());
  const JointCalibration claimed = AdjustJointly(overconfident, GlobalShutter());
  ASSERT_TRUE(joint.uncertainty.available && claimed.uncertainty.available);
  ASSERT_EQ(claimed.Joined(), 5);
  double sum = 0.0;
  for (const JointBurst& burst : overconfident) {
    const double sigma_px = burst.sigma_f_percent / 100.0 * burst.state.camera.f;
    sum += std::pow((burst.state.camera.f - claimed.fitted_camera.f) / sigma_px, 2);
  }
  EXPECT_NEAR(claimed.focal_dispersion, sum / 4.0, 1e-9 * sum);
  EXPECT_GT(claimed.focal_dispersion, 10.0 * joint.focal_dispersion);
  EXPECT_NEAR(claimed.fitted_camera.f, joint.fitted_camera.f, 1e-6 * joint.fitted_camera.f);
  EXPECT_NEAR(
      claimed.uncertainty.sigma_f_px(),
      joint.uncertainty.sigma_f_px() * std::sqrt(claimed.focal_dispersion / joint.focal_dispersion),
      1e-3 * claimed.uncertainty.sigma_f_px());
  EXPECT_NEAR(claimed.uncertainty.sigma_k1(), joint.uncertainty.sigma_k1(),
              1e-3 * joint.uncertainty.sigma_k1());
  EXPECT_NEAR(claimed.uncertainty.sigma_k2(), joint.uncertainty.sigma_k2(),
              1e-3 * joint.uncertainty.sigma_k2());
}

// Two bursts of two cameras cannot say which one is odd: both stay, and the
// verdict says they disagree.
TEST(JointAdjustment, TwoBurstsOfTwoCamerasAreSaidToDisagree) {
  std::vector<JointBurst> bursts = BurstsOfOneCamera(704.0, -0.06, 1, 11, 1.0, 0.05);
  bursts.push_back(BurstsOfOneCamera(560.0, -0.12, 1, 21, 1.0, 0.05).front());
  const JointCalibration joint = AdjustJointly(bursts, GlobalShutter());
  EXPECT_TRUE(joint.undecided);
  EXPECT_EQ(joint.Joined(), 2);
  EXPECT_NE(joint.verdict.quality, CalibrationQuality::kReliable);
  ASSERT_FALSE(joint.verdict.reasons.empty());
  EXPECT_NE(joint.verdict.reasons.back().find("too few to tell which one is odd"),
            std::string::npos)
      << joint.verdict.reasons.back();
  // Without a sigma of their own (0: unknown) the bursts leave f the
  // disagreement's dispersion.
  ASSERT_GT(joint.dispersion, 1.0);
  for (JointBurst& burst : bursts) burst.sigma_f_percent = 0.0;
  const JointCalibration unknown = AdjustJointly(bursts, GlobalShutter());
  EXPECT_EQ(unknown.focal_dispersion, unknown.dispersion);
  EXPECT_GT(unknown.focal_dispersion, 1.0);
}

// A burst adjusted under a known prior (EXIF, the daemon's joint or fused
// camera) or refitted under a fallback joins with the camera its own tracks
// chose: its disagreement is measured from its own minimum, so it is never
// negative. One without a camera of its own cannot join.
TEST(JointBurstOf, TakesTheBurstsOwnCameraNotAPriorsPullNorAFallbacks) {
  SparseOptions options = GlobalShutterSparse();
  KnownCalibration prior;
  prior.camera = CameraModel::Initial(640, 480);
  prior.camera.f = 760.0;  // 8 % off, held within 1 %
  prior.also_self_calibrate = true;
  prior.check_fit = false;
  options.known = prior;
  std::vector<SparseReconstruction> alone;
  const std::vector<JointBurst> bursts =
      BurstsOfOneCamera(704.0, -0.06, 4, 31, 0.5, 0.1, &alone, options);
  for (size_t b = 0; b < bursts.size(); ++b) {
    ASSERT_TRUE(alone[b].self_estimate.has_value());
    EXPECT_EQ(bursts[b].state.camera.f, alone[b].self_estimate->camera.f);
    EXPECT_GT(std::abs(alone[b].state.camera.f - bursts[b].state.camera.f), 1.0)
        << "the prior did not pull the burst's adjustment: the test shows nothing";
  }
  const JointCalibration joint = AdjustJointly(bursts, GlobalShutter());
  for (const JointBurstResult& burst : joint.bursts) EXPECT_GE(burst.disagreement, -1e-3);

  SparseReconstruction fallback = alone.front();
  fallback.self_estimate.reset();
  fallback.calibration_used = CalibrationSource::kFallbackK1;
  fallback.rejected_camera = CameraModel::Initial(640, 480);
  fallback.rejected_camera->f = 690.0;
  const JointBurst replaced = JointBurstOf("fallback", fallback);
  EXPECT_EQ(replaced.state.camera.f, 690.0);
  // The uncertainty is the refit's, not the replaced camera's: no sigma.
  ASSERT_TRUE(fallback.uncertainty.available);
  EXPECT_EQ(replaced.sigma_f_percent, 0.0);

  SparseReconstruction held = alone.front();
  held.self_estimate.reset();
  held.calibration_used = CalibrationSource::kKnownFixed;
  EXPECT_THROW(JointBurstOf("held", held), std::invalid_argument);
}

// Every burst's inverse depths held at the truth's (at its solution's scale),
// noise-free tracks: the camera then comes from the poses alone and is the
// truth's, and neither a covariance nor a noise bias is claimed for it.
TEST(JointAdjustment, HoldsTheInverseDepthsWhereTheOptionsSay) {
  std::vector<TrackSimulation> sims;
  std::vector<JointBurst> bursts =
      BurstsOfOneCamera(704.0, -0.06, 4, 31, 1.0, 0.0, nullptr, GlobalShutterSparse(), &sims);
  for (size_t b = 0; b < bursts.size(); ++b) {
    std::vector<double>& inverse_depths = bursts[b].state.inverse_depths;
    const std::vector<double>& truth = sims[b].inverse_depths;
    std::vector<double> ratios;
    for (size_t j = 0; j < truth.size(); ++j)
      if (bursts[b].use[j]) ratios.push_back(inverse_depths[j] / truth[j]);
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    const double scale = ratios[ratios.size() / 2];
    for (size_t j = 0; j < truth.size(); ++j) inverse_depths[j] = scale * truth[j];
  }
  JointAdjustmentOptions held = GlobalShutter();
  held.bundle_adjustment.hold_inverse_depths = true;
  const JointCalibration joint = AdjustJointly(bursts, held);
  EXPECT_EQ(joint.Joined(), 4);
  EXPECT_NEAR(joint.fitted_camera.f, 704.0, 0.001 * 704.0);
  EXPECT_FALSE(joint.uncertainty.available);
  EXPECT_EQ(joint.uncertainty.unavailable_reason, "the inverse depths are held");
  EXPECT_FALSE(joint.bias.has_value());
}

TEST(JointAdjustment, RefusesBurstsOfDifferentSizes) {
  std::vector<JointBurst> bursts = BurstsOfOneCamera(704.0, -0.06, 2, 11, 1.0, 0.05);
  bursts[1].state.camera.width = 320;
  try {
    AdjustJointly(bursts, GlobalShutter());
    ADD_FAILURE() << "bursts of two sizes were adjusted jointly";
  } catch (const ReconstructionError& e) {
    EXPECT_NE(std::string(e.what()).find("different image sizes"), std::string::npos) << e.what();
  }
}

TEST(JointAdjustmentOptions, AnOptionOutOfItsRangeIsRefusedByName) {
  const std::vector<std::pair<std::string, void (*)(JointAdjustmentOptions*)>> cases = {
      {"consistency_probability",
       [](JointAdjustmentOptions* o) { o->consistency_probability = 1; }},
      {"max_starts", [](JointAdjustmentOptions* o) { o->max_starts = 0; }},
      {"min_bursts_to_leave_out",
       [](JointAdjustmentOptions* o) { o->min_bursts_to_leave_out = 3; }},
      {"profile_iterations", [](JointAdjustmentOptions* o) { o->profile_iterations = 0; }},
      {"fix_intrinsics",
       [](JointAdjustmentOptions* o) { o->bundle_adjustment.fix_intrinsics = true; }},
      {"distortion_terms",
       [](JointAdjustmentOptions* o) { o->bundle_adjustment.distortion_terms = 3; }},
      {"replicas", [](JointAdjustmentOptions* o) { o->bootstrap.replicas = -1; }},
      {"angular_velocity_sigma_px",
       [](JointAdjustmentOptions* o) { o->bundle_adjustment.angular_velocity_sigma_px = 2.0; }},
  };
  for (const auto& [name, spoil] : cases) {
    JointAdjustmentOptions options;
    spoil(&options);
    try {
      options.Check();
      ADD_FAILURE() << name << " out of range was not refused";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << name << ": " << e.what();
    }
  }
}

}  // namespace
}  // namespace dfsm
