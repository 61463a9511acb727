#include "core/pipeline/depth_check.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace dfsm {
namespace {

// Four inlier tracks on a dense map that agrees with them everywhere: only
// what the test changes can warn. The tracks moved `parallax_px` beyond the
// camera's rotation.
struct AgreeingBurst {
  SparseReconstruction sparse;
  DenseDepth dense;

  explicit AgreeingBurst(double parallax_px = 1.0) {
    sparse.tracks.reference = 0;
    Eigen::Matrix2Xd pixels(2, 4);
    pixels << 2, 10, 17, 5, 3, 12, 8, 16;
    sparse.tracks.pixels = {pixels};
    sparse.inliers = {true, true, true, true};
    sparse.parallax.median_px = parallax_px;
    sparse.state.inverse_depths = {0.5, 0.5, 0.5, 0.5};
    dense.depth = cv::Mat(20, 20, CV_32FC1, cv::Scalar(2.0f));
    dense.valid_fraction = 1.0;
  }
};

TEST(DepthCheck, AReliefTheCameraLeavesUncertainWarnsWithItsSigma) {
  AgreeingBurst burst;
  DepthCheckOptions options;
  burst.sparse.uncertainty.relief_sigma = 0.02;
  DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense, options);
  EXPECT_TRUE(check.warnings.empty()) << check.warnings.front();
  EXPECT_EQ(check.compared, 4);
  EXPECT_DOUBLE_EQ(check.relief_sigma, 0.02);

  burst.sparse.uncertainty.relief_sigma = 0.08;
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense, options);
  ASSERT_EQ(check.warnings.size(), 1u);
  EXPECT_NE(check.warnings[0].find("depth relief uncertain"), std::string::npos);
  EXPECT_NE(check.warnings[0].find("by 8 %"), std::string::npos) << check.warnings[0];
  const nlohmann::json json = ToJson(check);
  EXPECT_DOUBLE_EQ(json.at("relief_sigma").get<double>(), 0.08);
  EXPECT_FALSE(json.at("confirmed").get<bool>());
}

// Where the covariance could not be formed (-1) there is nothing to warn of.
TEST(DepthCheck, AnUnknownReliefSigmaDoesNotWarn) {
  AgreeingBurst burst;
  burst.sparse.uncertainty.relief_sigma = -1.0;
  const DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_TRUE(check.warnings.empty());
  EXPECT_TRUE(ToJson(check).at("confirmed").get<bool>());
}

// A relief that moves with the lens model (SparseReconstruction::
// lens_relief_shift) warns with the shift; -1 (not measured) does not.
TEST(DepthCheck, AReliefThatDependsOnTheLensModelWarns) {
  AgreeingBurst burst;
  burst.sparse.lens_relief_shift = 0.02;
  DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_TRUE(check.warnings.empty()) << check.warnings.front();

  burst.sparse.lens_relief_shift = 0.34;
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  ASSERT_EQ(check.warnings.size(), 1u);
  EXPECT_NE(check.warnings[0].find("depends on the lens model"), std::string::npos);
  EXPECT_NE(check.warnings[0].find("by 34 %"), std::string::npos) << check.warnings[0];
  const nlohmann::json json = ToJson(check);
  EXPECT_DOUBLE_EQ(json.at("lens_relief_shift").get<double>(), 0.34);
  EXPECT_FALSE(json.at("confirmed").get<bool>());

  burst.sparse.lens_relief_shift = -1.0;
  EXPECT_TRUE(CheckDepthAgainstTracks(burst.sparse, burst.dense).warnings.empty());
}

// A relief that moves with the camera (SparseReconstruction::
// camera_relief_disagreement: the burst calibrated alone beside a known
// camera) withholds `confirmed` from 7.5 % and makes the map unreliable from a
// quarter; -1 (not measured) says nothing.
TEST(DepthCheck, AReliefThatDependsOnTheCameraIsNotConfirmed) {
  AgreeingBurst burst;
  burst.sparse.camera_relief_disagreement = 0.05;
  DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_EQ(check.quality, DepthQuality::kConfirmed);

  burst.sparse.camera_relief_disagreement = 0.11;
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  ASSERT_EQ(check.warnings.size(), 1u);
  EXPECT_NE(check.warnings[0].find("depth relief depends on the camera"), std::string::npos);
  EXPECT_NE(check.warnings[0].find("by 11 %"), std::string::npos) << check.warnings[0];
  EXPECT_EQ(check.quality, DepthQuality::kUncertain);
  EXPECT_DOUBLE_EQ(ToJson(check).at("camera_relief_disagreement").get<double>(), 0.11);

  burst.sparse.camera_relief_disagreement = 0.66;
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_EQ(check.quality, DepthQuality::kUnreliable);
  ASSERT_EQ(check.unreliable_reasons.size(), 1u);
  EXPECT_NE(check.unreliable_reasons[0].find("moves by 66 % with the camera"), std::string::npos)
      << check.unreliable_reasons[0];

  burst.sparse.camera_relief_disagreement = -1.0;
  EXPECT_EQ(CheckDepthAgainstTracks(burst.sparse, burst.dense).quality, DepthQuality::kConfirmed);

  DepthCheckOptions bad;
  bad.max_camera_relief_disagreement = 0.0;
  EXPECT_THROW(CheckDepthAgainstTracks(burst.sparse, burst.dense, bad), std::invalid_argument);
}

// A map computed with a camera refitted with fewer lens terms than the
// adjustment estimated (the dense stage could not invert the estimate) agrees
// with the refit's tracks, which confirms nothing: the check says so in its
// JSON and withholds `confirmed`; the sparse stage's warning says why.
TEST(DepthCheck, AFallbackCameraIsNotConfirmed) {
  AgreeingBurst burst;
  for (const CalibrationSource used :
       {CalibrationSource::kSelf, CalibrationSource::kKnownFixed, CalibrationSource::kKnownPrior,
        CalibrationSource::kFallbackKnown}) {
    burst.sparse.calibration_used = used;
    const DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
    EXPECT_TRUE(check.estimated_camera_used) << CalibrationSourceName(used);
    EXPECT_TRUE(check.Confirmed()) << CalibrationSourceName(used);
  }
  for (const CalibrationSource used :
       {CalibrationSource::kFallbackK1, CalibrationSource::kFallbackK0}) {
    burst.sparse.calibration_used = used;
    const DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
    EXPECT_TRUE(check.warnings.empty()) << CalibrationSourceName(used);
    EXPECT_FALSE(check.estimated_camera_used) << CalibrationSourceName(used);
    const nlohmann::json json = ToJson(check);
    EXPECT_FALSE(json.at("estimated_camera_used").get<bool>()) << CalibrationSourceName(used);
    EXPECT_FALSE(json.at("confirmed").get<bool>()) << CalibrationSourceName(used);
  }
}

// A surface nearer (or farther) than every track is swept only to the range's
// end and takes the end plane: above 3 % of the measured pixels there, the
// depth is not confirmed, and below it says nothing.
TEST(DepthCheck, PixelsAtAnEndOfTheSweptRangeWarnThatTheDepthIsClamped) {
  AgreeingBurst burst;
  burst.dense.min_inverse_depth = 0.25;  // the map's 0.5 lies inside
  burst.dense.max_inverse_depth = 1.0;
  burst.dense.planes = 128;
  DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_TRUE(check.warnings.empty()) << check.warnings.front();
  EXPECT_EQ(check.at_nearest_plane, 0.0);

  burst.dense.depth(cv::Rect(0, 0, 10, 1)).setTo(1.0f);  // 10 of 400 pixels at the nearest plane
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_TRUE(check.warnings.empty()) << check.warnings.front();
  EXPECT_DOUBLE_EQ(check.at_nearest_plane, 10.0 / 400.0);

  burst.dense.depth(cv::Rect(0, 0, 20, 2)).setTo(1.0f);  // 40: a tenth
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  ASSERT_EQ(check.warnings.size(), 1u);
  EXPECT_NE(check.warnings[0].find("10 % of the measured pixels sit at the nearest swept depth"),
            std::string::npos)
      << check.warnings[0];
  EXPECT_FALSE(ToJson(check).at("confirmed").get<bool>());

  burst.dense.depth(cv::Rect(0, 0, 20, 2)).setTo(2.0f);
  burst.dense.depth(cv::Rect(0, 18, 20, 2)).setTo(4.0f);  // the farthest plane
  burst.dense.depth(cv::Rect(0, 10, 20, 2)).setTo(0.0f);  // unmeasured pixels do not count
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  ASSERT_EQ(check.warnings.size(), 1u);
  EXPECT_DOUBLE_EQ(check.at_farthest_plane, 40.0 / 360.0);
  EXPECT_NE(check.warnings[0].find("sit at the farthest swept depth"), std::string::npos)
      << check.warnings[0];
  EXPECT_DOUBLE_EQ(ToJson(check).at("at_farthest_plane").get<double>(), 40.0 / 360.0);
  EXPECT_FALSE(ToJson(check).at("range_extended").get<bool>());
  burst.dense.range_extended = true;
  EXPECT_TRUE(
      ToJson(CheckDepthAgainstTracks(burst.sparse, burst.dense)).at("range_extended").get<bool>());
}

// A known calibration that does not fit the burst placed the tracks too: a map
// that agrees with them is not confirmed, and the check adds no warning of its
// own (the sparse stage's says why). One that fits, or none, changes nothing.
TEST(DepthCheck, AKnownCalibrationThatDoesNotFitWithholdsConfirmation) {
  AgreeingBurst burst;
  EXPECT_TRUE(
      ToJson(CheckDepthAgainstTracks(burst.sparse, burst.dense)).at("confirmed").get<bool>());

  burst.sparse.known_fit.emplace();
  burst.sparse.known_fit->fits = true;
  DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_TRUE(check.Confirmed());
  EXPECT_TRUE(ToJson(check).at("known_calibration_fits").get<bool>());

  burst.sparse.known_fit->fits = false;
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_TRUE(check.warnings.empty()) << check.warnings.front();
  EXPECT_FALSE(check.Confirmed());
  const nlohmann::json json = ToJson(check);
  EXPECT_FALSE(json.at("known_calibration_fits").get<bool>());
  EXPECT_FALSE(json.at("confirmed").get<bool>());
}

// The verdict on the map as a whole: confirmed where nothing warns, uncertain
// where a warning applies, unreliable from a quarter of relief uncertainty,
// relief shift, disagreement or pixels at a range end, each reason with its
// measure.
TEST(DepthCheck, AMapLikelyWrongAsAWholeIsUnreliableWithItsReasons) {
  AgreeingBurst burst;
  DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_EQ(check.quality, DepthQuality::kConfirmed);
  EXPECT_TRUE(check.unreliable_reasons.empty());

  burst.sparse.uncertainty.relief_sigma = 0.12;
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_EQ(check.quality, DepthQuality::kUncertain);
  EXPECT_TRUE(check.unreliable_reasons.empty());

  burst.sparse.uncertainty.relief_sigma = 0.26;
  burst.sparse.lens_relief_shift = 0.4;
  check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_EQ(check.quality, DepthQuality::kUnreliable);
  ASSERT_EQ(check.unreliable_reasons.size(), 2u);
  EXPECT_NE(check.unreliable_reasons[0].find("relief uncertain by 26 %"), std::string::npos)
      << check.unreliable_reasons[0];
  EXPECT_NE(check.unreliable_reasons[1].find("moves by 40 %"), std::string::npos)
      << check.unreliable_reasons[1];
  const nlohmann::json verdict = DepthVerdictJson(check);
  EXPECT_EQ(verdict.at("quality"), "unreliable");
  EXPECT_EQ(verdict.at("reasons").size(), 2u);

  // A map that disagrees with its tracks by a median of a third.
  AgreeingBurst far;
  far.dense.depth.setTo(3.0f);
  check = CheckDepthAgainstTracks(far.sparse, far.dense);
  EXPECT_EQ(check.quality, DepthQuality::kUnreliable);
  ASSERT_EQ(check.unreliable_reasons.size(), 1u);
  EXPECT_NE(check.unreliable_reasons[0].find("disagrees with the tracks by a median of 33 %"),
            std::string::npos)
      << check.unreliable_reasons[0];

  // A known calibration that does not fit withholds confirmation only.
  AgreeingBurst known;
  known.sparse.known_fit.emplace();
  known.sparse.known_fit->fits = false;
  EXPECT_EQ(CheckDepthAgainstTracks(known.sparse, known.dense).quality, DepthQuality::kUncertain);

  DepthCheckOptions bad;
  bad.unreliable_range_end_fraction = 0.0;
  EXPECT_THROW(CheckDepthAgainstTracks(burst.sparse, burst.dense, bad), std::invalid_argument);
}

// A burst that barely moved beyond its rotation cannot separate depths,
// however well its map agrees with its tracks: the map is unreliable and the
// warning says what to do. Above the bound nothing is said.
TEST(DepthCheck, ABurstTooStillForDepthIsUnreliableAndSaysToMoveTheCamera) {
  DepthCheckOptions options;
  ASSERT_DOUBLE_EQ(options.min_parallax_px, kTooStillParallaxPx);
  DepthCheck check = CheckDepthAgainstTracks(AgreeingBurst(0.3).sparse, AgreeingBurst().dense);
  EXPECT_NEAR(check.parallax_px, 0.3, 1e-9);
  EXPECT_EQ(check.quality, DepthQuality::kUnreliable);
  ASSERT_EQ(check.unreliable_reasons.size(), 1u);
  EXPECT_NE(check.unreliable_reasons[0].find("moved 0.30 px beyond the camera's rotation"),
            std::string::npos)
      << check.unreliable_reasons[0];
  ASSERT_EQ(check.warnings.size(), 1u);
  EXPECT_EQ(check.warnings[0].rfind("move the camera a little", 0), 0u) << check.warnings[0];
  EXPECT_NE(check.warnings[0].find("depth needs 0.50 px"), std::string::npos) << check.warnings[0];

  check = CheckDepthAgainstTracks(AgreeingBurst(0.6).sparse, AgreeingBurst().dense);
  EXPECT_EQ(check.quality, DepthQuality::kConfirmed);
  EXPECT_TRUE(check.warnings.empty()) << check.warnings.front();

  options.min_parallax_px = 0.2;  // dfsmd's pipeline.still_parallax_px
  check = CheckDepthAgainstTracks(AgreeingBurst(0.3).sparse, AgreeingBurst().dense, options);
  EXPECT_EQ(check.quality, DepthQuality::kConfirmed);
  options.min_parallax_px = -1.0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

// A map made with an implausible estimated camera (f a dozen times the image
// size) agrees with its tracks and has a tiny relief sigma: both are measured
// in that camera. It is unreliable, never confirmed.
TEST(DepthCheck, AMapFromAnImplausibleCameraIsUnreliable) {
  AgreeingBurst burst;
  burst.sparse.implausible_camera = {"implausible focal length: f 24785.8 px is 12.91 x"};
  const DepthCheck check = CheckDepthAgainstTracks(burst.sparse, burst.dense);
  EXPECT_EQ(check.quality, DepthQuality::kUnreliable);
  ASSERT_EQ(check.unreliable_reasons.size(), 1u);
  EXPECT_EQ(check.unreliable_reasons[0],
            "the camera the burst estimated for it is implausible: implausible focal length: f "
            "24785.8 px is 12.91 x");
}

}  // namespace
}  // namespace dfsm
