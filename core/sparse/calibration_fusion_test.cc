#include "core/sparse/calibration_fusion.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

namespace dfsm {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

CameraModel Truth(double f = 1000.0) {
  CameraModel camera = CameraModel::Initial(1280, 720);
  camera.f = f;
  camera.k1 = -0.08;
  camera.k2 = 0.02;
  return camera;
}

// A covariance with the correlations small motion gives: f and k1 trade
// against each other, k1 and k2 strongly.
Eigen::Matrix3d Covariance(double sigma_f, double sigma_k1, double sigma_k2) {
  Eigen::Matrix3d correlation;
  correlation << 1.0, 0.6, -0.4, 0.6, 1.0, -0.8, -0.4, -0.8, 1.0;
  const Eigen::Vector3d sigma(sigma_f, sigma_k1, sigma_k2);
  return sigma.asDiagonal() * correlation * sigma.asDiagonal();
}

CalibrationSample Sample(const Eigen::Vector3d& theta, const Eigen::Matrix3d& covariance,
                         const std::string& job, double f_truth = 1000.0) {
  CalibrationSample sample;
  sample.camera = Truth(f_truth);
  sample.camera.f = theta(0);
  sample.camera.k1 = theta(1);
  sample.camera.k2 = theta(2);
  sample.covariance = covariance;
  sample.job = job;
  sample.time_ms = 1000 * static_cast<int64_t>(job.size());
  return sample;
}

// One burst's estimate of `truth`: the truth plus noise of the given covariance.
CalibrationSample Draw(std::mt19937* rng, const Eigen::Matrix3d& covariance,
                       const std::string& job = "burst", double f_truth = 1000.0) {
  std::normal_distribution<double> normal;
  const Eigen::Vector3d z(normal(*rng), normal(*rng), normal(*rng));
  const CameraModel truth = Truth(f_truth);
  const Eigen::Vector3d theta = Eigen::Vector3d(truth.f, truth.k1, truth.k2) +
                                Eigen::Matrix3d(covariance.llt().matrixL()) * z;
  return Sample(theta, covariance, job, f_truth);
}

Eigen::Vector3d Estimate(const CalibrationFusion& fusion) {
  const CameraModel camera = fusion.camera();
  return {camera.f, camera.k1, camera.k2};
}

// A fusion of `n` samples of the true camera, every one fused.
CalibrationFusion Fused(std::mt19937* rng, int n, const Eigen::Matrix3d& covariance) {
  CalibrationFusion fusion;
  for (int i = 0; i < n; ++i) fusion.Add(Draw(rng, covariance, "burst-" + std::to_string(i)));
  EXPECT_EQ(fusion.bursts(), n);
  return fusion;
}

TEST(ChiSquare, QuantilesMatchTheTables) {
  EXPECT_NEAR(ChiSquareQuantile(0.95, 3), 7.814728, 1e-5);
  EXPECT_NEAR(ChiSquareQuantile(0.99, 3), 11.344867, 1e-5);
  EXPECT_NEAR(ChiSquareQuantile(0.999, 3), 16.266236, 1e-5);
  EXPECT_NEAR(ChiSquareQuantile(0.95, 1), 3.841459, 1e-5);
  EXPECT_NEAR(ChiSquareQuantile(0.99, 2), -2.0 * std::log(0.01), 1e-9);  // exact for 2 dof
  EXPECT_NEAR(ChiSquareQuantile(0.95, 10), 18.307038, 1e-5);
  // 3 dof in closed form: erf(sqrt(x/2)) - sqrt(2x/pi) exp(-x/2).
  for (double x : {0.1, 1.0, 5.0, 16.0, 40.0}) {
    const double closed =
        std::erf(std::sqrt(x / 2)) - std::sqrt(2 * x / std::acos(-1.0)) * std::exp(-x / 2);
    EXPECT_NEAR(ChiSquareCdf(x, 3), closed, 1e-13) << x;
  }
  EXPECT_THROW(ChiSquareQuantile(1.0, 3), std::invalid_argument);
  EXPECT_NEAR(CalibrationFusion().consistency_gate(), 16.266236, 1e-5);
}

TEST(CalibrationFusionOptions, CheckNamesTheBadField) {
  CalibrationFusionOptions options;
  options.consistency_probability = 1.0;
  try {
    CalibrationFusion fusion(options);
    FAIL() << "accepted consistency_probability 1";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("consistency_probability"), std::string::npos);
  }
  options = {};
  options.history_limit = -1;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

TEST(CalibrationFusion, WeighsEachBurstByItsInformation) {
  // C and 4 C: the first counts four times as much, and the fused
  // covariance is (C^-1 + C^-1 / 4)^-1 = 0.8 C.
  const Eigen::Matrix3d C = Covariance(10.0, 0.01, 0.02);
  const Eigen::Vector3d a(1005.0, -0.081, 0.021), b(990.0, -0.075, 0.018);
  CalibrationFusion fusion;
  EXPECT_EQ(fusion.Add(Sample(a, C, "a")), FusionOutcome::kStarted);
  EXPECT_EQ(fusion.Add(Sample(b, 4.0 * C, "b")), FusionOutcome::kFused);
  EXPECT_LT((Estimate(fusion) - (4.0 * a + b) / 5.0).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((fusion.covariance() - 0.8 * C).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(fusion.sigma_f_percent(), 100.0 * std::sqrt(8.0 * 10.0) / fusion.camera().f, 1e-9);
}

TEST(CalibrationFusion, SigmaShrinksLikeOneOverRootNAndTheErrorWithIt) {
  const Eigen::Matrix3d C = Covariance(10.0, 0.01, 0.02);
  std::mt19937 rng(7);
  const CalibrationFusion one = Fused(&rng, 1, C), four = Fused(&rng, 4, C);
  EXPECT_NEAR(one.sigma_f_percent() / four.sigma_f_percent(), 2.0, 0.2);
  EXPECT_NEAR(one.sigma_f_percent(), 1.0, 0.02);  // 10 px of 1000
  // Over many independent fusions: the error of 16 bursts is a quarter of one
  // burst's, and the fused covariance describes it (d^T Lambda d averages 3).
  constexpr int kTrials = 400;
  double sq_1 = 0.0, sq_16 = 0.0, chi2_16 = 0.0;
  int complete = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    CalibrationFusion single, sixteen;
    single.Add(Draw(&rng, C));
    for (int i = 0; i < 16; ++i) sixteen.Add(Draw(&rng, C));
    complete += sixteen.bursts() == 16;
    const CameraModel truth = Truth();
    const Eigen::Vector3d d = Estimate(sixteen) - Eigen::Vector3d(truth.f, truth.k1, truth.k2);
    sq_1 += std::pow(single.camera().f - truth.f, 2);
    sq_16 += d(0) * d(0);
    chi2_16 += d.dot(sixteen.covariance().llt().solve(d));
  }
  EXPECT_GE(complete, kTrials * 0.97);  // the gate lets 0.1 % of honest bursts out
  EXPECT_NEAR(std::sqrt(sq_1 / sq_16), 4.0, 0.6);
  EXPECT_NEAR(chi2_16 / kTrials, 3.0, 0.3);
  // One fusion of bursts of differing quality: within 3 sigma of the truth.
  CalibrationFusion mixed;
  for (int i = 0; i < 12; ++i) mixed.Add(Draw(&rng, (0.5 + 0.25 * (i % 6)) * C));
  ASSERT_EQ(mixed.bursts(), 12);
  const Eigen::Vector3d error = Estimate(mixed) - Eigen::Vector3d(1000.0, -0.08, 0.02);
  for (int k = 0; k < 3; ++k)
    EXPECT_LT(std::abs(error(k)), 3 * std::sqrt(mixed.covariance()(k, k)));
}

TEST(CalibrationFusion, OrderOfAddingDoesNotMatter) {
  std::mt19937 rng(11);
  std::vector<CalibrationSample> samples;
  for (int i = 0; i < 10; ++i)
    samples.push_back(Draw(&rng, (0.3 + 0.4 * i) * Covariance(8.0, 0.01, 0.02), std::to_string(i)));
  const auto fuse = [](const std::vector<CalibrationSample>& order) {
    CalibrationFusion fusion;
    for (const CalibrationSample& s : order) fusion.Add(s);
    EXPECT_EQ(fusion.bursts(), 10);
    return fusion;
  };
  const CalibrationFusion forward = fuse(samples);
  std::vector<CalibrationSample> reversed(samples.rbegin(), samples.rend()), shuffled = samples;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  for (const CalibrationFusion& other : {fuse(reversed), fuse(shuffled)}) {
    const Eigen::Vector3d scale = forward.covariance().diagonal().cwiseSqrt();
    EXPECT_LT(((Estimate(other) - Estimate(forward)).cwiseQuotient(scale)).cwiseAbs().maxCoeff(),
              1e-9);
    EXPECT_LT(
        ((other.covariance() - forward.covariance()).array() / (scale * scale.transpose()).array())
            .abs()
            .maxCoeff(),
        1e-9);
  }
}

TEST(CalibrationFusion, OneGrossOutlierIsLeftOutAndTheFusionGoesOn) {
  const Eigen::Matrix3d C = Covariance(10.0, 0.01, 0.02);
  std::mt19937 rng(3);
  CalibrationFusion fusion = Fused(&rng, 6, C);
  const CameraModel before = fusion.camera();
  CalibrationSample gross = Draw(&rng, C, "gross");
  gross.camera.f += 50 * 10.0;
  std::string reason;
  EXPECT_EQ(fusion.Add(gross, &reason), FusionOutcome::kOutlier);
  EXPECT_NE(reason.find("left out"), std::string::npos) << reason;
  EXPECT_GT(fusion.history().back().chi2, 1000.0);
  EXPECT_EQ(fusion.camera().f, before.f);
  EXPECT_EQ(fusion.camera().k1, before.k1);
  EXPECT_EQ(fusion.bursts(), 6);
  ASSERT_TRUE(fusion.pending_outlier().has_value());
  EXPECT_EQ(fusion.Add(Draw(&rng, C, "good")), FusionOutcome::kFused);
  EXPECT_EQ(fusion.bursts(), 7);
  EXPECT_FALSE(fusion.pending_outlier().has_value());
  // Two failures in a row that disagree with each other are two outliers,
  // not a changed camera.
  gross.camera.f = 1500.0;
  EXPECT_EQ(fusion.Add(gross), FusionOutcome::kOutlier);
  gross.camera.f = 500.0;
  EXPECT_EQ(fusion.Add(gross), FusionOutcome::kOutlier);
  EXPECT_EQ(fusion.bursts(), 7);
  EXPECT_EQ(fusion.counts().outliers, 3);
  EXPECT_EQ(fusion.counts().restarts, 0);
}

TEST(CalibrationFusion, TwoConsistentFailuresMeanTheCameraChanged) {
  const Eigen::Matrix3d C = Covariance(10.0, 0.01, 0.02);
  std::mt19937 rng(5);
  CalibrationFusion fusion = Fused(&rng, 6, C);
  EXPECT_EQ(fusion.Add(Draw(&rng, C, "zoomed-1", 1100.0)), FusionOutcome::kOutlier);
  std::string reason;
  EXPECT_EQ(fusion.Add(Draw(&rng, C, "zoomed-2", 1100.0), &reason),
            FusionOutcome::kRestartedAfterChange);
  EXPECT_NE(reason.find("zoomed-1"), std::string::npos) << reason;
  EXPECT_EQ(fusion.bursts(), 2);
  EXPECT_NEAR(fusion.camera().f, 1100.0, 3 * std::sqrt(fusion.covariance()(0, 0)));
  EXPECT_NEAR(fusion.sigma_f_percent(), 100.0 * 10.0 / std::sqrt(2.0) / 1100.0, 0.02);
  EXPECT_EQ(fusion.Add(Draw(&rng, C, "zoomed-3", 1100.0)), FusionOutcome::kFused);
  EXPECT_EQ(fusion.bursts(), 3);
  EXPECT_EQ(fusion.history().back().fused_bursts_after, 3);
  EXPECT_EQ(fusion.counts().restarts, 1);
}

TEST(CalibrationFusion, RefusesWhatItCannotFuse) {
  const Eigen::Matrix3d C = Covariance(10.0, 0.01, 0.02);
  std::mt19937 rng(9);
  CalibrationFusion fusion = Fused(&rng, 3, C);
  EXPECT_EQ(fusion.Add(Draw(&rng, C, "zoomed-1", 1100.0)), FusionOutcome::kOutlier);
  const CameraModel before = fusion.camera();
  const auto expect_refused = [&](CalibrationSample sample, const std::string& why) {
    std::string reason;
    EXPECT_EQ(fusion.Add(sample, &reason), FusionOutcome::kRefused) << why;
    EXPECT_NE(reason.find(why), std::string::npos) << reason;
    EXPECT_EQ(fusion.camera().f, before.f);
    EXPECT_EQ(fusion.bursts(), 3);
    EXPECT_TRUE(std::isnan(fusion.history().back().chi2));
  };
  CalibrationSample other = Draw(&rng, C);
  other.camera.width = 1920;
  other.camera.height = 1080;
  expect_refused(other, "1920x1080");
  other = Draw(&rng, C);
  other.camera.cx += 1.0;
  expect_refused(other, "principal point (641.000, 360.000)");
  other = Draw(&rng, C);
  other.covariance.bottomRightCorner<2, 2>().setZero();  // k1, k2 held fixed
  other.covariance.block<1, 2>(0, 1).setZero();
  other.covariance.block<2, 1>(1, 0).setZero();
  expect_refused(other, "positive definite");
  other.covariance = Covariance(10.0, 0.01, 0.02);
  other.covariance(0, 1) = other.covariance(1, 0) = 1.01 * 10.0 * 0.01;  // |correlation| > 1
  expect_refused(other, "positive definite");
  other.covariance = C;
  other.covariance(0, 2) = kNaN;
  expect_refused(other, "not finite");
  other.covariance = C;
  other.covariance(0, 1) *= 2.0;
  expect_refused(other, "not symmetric");
  other = Draw(&rng, C);
  other.camera.f = kNaN;
  expect_refused(other, "not finite");
  EXPECT_EQ(fusion.counts().refused, 7);
  // Refusals are no evidence about the camera: the pending outlier still
  // pairs with the next changed burst.
  EXPECT_EQ(fusion.Add(Draw(&rng, C, "zoomed-2", 1100.0)), FusionOutcome::kRestartedAfterChange);
  CalibrationFusion empty;
  EXPECT_EQ(empty.Add(other), FusionOutcome::kRefused);
  EXPECT_TRUE(empty.empty());
  EXPECT_THROW(empty.camera(), std::logic_error);
}

TEST(CalibrationFusion, ReliableNeedsEnoughBurstsAndSmallSigmas) {
  // 0.6 % per burst: over the threshold alone, under it from two bursts on.
  const Eigen::Matrix3d C = Covariance(6.0, 0.0005, 0.001);
  std::mt19937 rng(13);
  CalibrationFusion fusion;
  EXPECT_FALSE(fusion.reliable());
  EXPECT_EQ(fusion.UnreliableReasons(), std::vector<std::string>{"no burst fused yet"});
  fusion.Add(Draw(&rng, C));
  EXPECT_NEAR(fusion.sigma_f_percent(), 0.6, 0.01);
  EXPECT_FALSE(fusion.reliable());
  ASSERT_EQ(fusion.UnreliableReasons().size(), 2u);
  EXPECT_EQ(fusion.UnreliableReasons()[0], "1 of 3 bursts fused");
  EXPECT_EQ(fusion.UnreliableReasons()[1].rfind("focal length sigma 0.6", 0), 0u)
      << fusion.UnreliableReasons()[1];
  fusion.Add(Draw(&rng, C));
  EXPECT_LT(fusion.sigma_f_percent(), 0.5);
  EXPECT_LT(fusion.distortion_sigma_px(), 0.25);
  EXPECT_FALSE(fusion.reliable());  // 2 < min_bursts_for_reliable
  EXPECT_EQ(fusion.UnreliableReasons(), std::vector<std::string>{"2 of 3 bursts fused"});
  fusion.Add(Draw(&rng, C));
  EXPECT_NEAR(fusion.sigma_f_percent(), 0.6 / std::sqrt(3.0), 0.01);
  EXPECT_TRUE(fusion.reliable());
  EXPECT_TRUE(fusion.UnreliableReasons().empty());
  fusion.Reset();
  EXPECT_TRUE(fusion.empty());
  EXPECT_FALSE(fusion.reliable());
  EXPECT_EQ(fusion.history().size(), 3u);  // the log outlives the reset
  // Many bursts of a distortion the bursts barely see: sigma_f small, the
  // distortion's sigma not.
  for (int i = 0; i < 5; ++i) fusion.Add(Draw(&rng, Covariance(2.0, 0.05, 0.1)));
  EXPECT_LT(fusion.sigma_f_percent(), 0.5);
  EXPECT_GT(fusion.distortion_sigma_px(), 0.25);
  EXPECT_FALSE(fusion.reliable());
}

TEST(CalibrationFusion, HistoryKeepsTheNewestEntries) {
  CalibrationFusionOptions options;
  options.history_limit = 3;
  CalibrationFusion fusion(options);
  std::mt19937 rng(17);
  for (int i = 0; i < 5; ++i) fusion.Add(Draw(&rng, Covariance(10, 0.01, 0.02), std::to_string(i)));
  ASSERT_EQ(fusion.history().size(), 3u);
  EXPECT_EQ(fusion.history().front().job, "2");
  EXPECT_EQ(fusion.history().back().job, "4");
  EXPECT_EQ(fusion.history().back().fused_bursts_after, 5);
  EXPECT_EQ(fusion.history().back().fused_f_after, fusion.camera().f);
  options.history_limit = 2;
  EXPECT_EQ(CalibrationFusion::FromJson(fusion.ToJson(), options).history().front().job, "3");
}

// A fusion with every kind of state: fused bursts, a pending outlier, a
// refused sample whose numbers are NaN (null in JSON).
CalibrationFusion Eventful(std::mt19937* rng) {
  const Eigen::Matrix3d C = Covariance(10.0, 0.01, 0.02);
  CalibrationFusion fusion = Fused(rng, 5, C);
  EXPECT_EQ(fusion.Add(Draw(rng, C, "zoomed-1", 1100.0)), FusionOutcome::kOutlier);
  CalibrationSample broken = Draw(rng, C, "broken");
  broken.camera.f = kNaN;
  EXPECT_EQ(fusion.Add(broken), FusionOutcome::kRefused);
  return fusion;
}

TEST(CalibrationFusionJson, RoundTripRestoresTheStateExactly) {
  std::mt19937 rng(19);
  CalibrationFusion original = Eventful(&rng);
  const nlohmann::json j = original.ToJson();
  EXPECT_EQ(j["bursts"], 5);
  EXPECT_EQ(j["empty"], false);
  EXPECT_EQ(j["camera"]["fx"].get<double>(), original.camera().f);
  EXPECT_EQ(j["sigma_f_percent"].get<double>(), original.sigma_f_percent());
  EXPECT_TRUE(j["reliable"].is_boolean());
  EXPECT_TRUE(j["history"].back()["f"].is_null());
  const std::string text = j.dump(2);
  CalibrationFusion restored = CalibrationFusion::FromJson(nlohmann::json::parse(text));
  EXPECT_EQ(restored.ToJson().dump(2), text);
  EXPECT_EQ(restored.covariance(), original.covariance());
  ASSERT_TRUE(restored.pending_outlier().has_value());
  EXPECT_EQ(restored.pending_outlier()->covariance, original.pending_outlier()->covariance);
  EXPECT_TRUE(std::isnan(restored.history().back().chi2));
  // The same next bursts do the same to both: the restart from the pending
  // outlier, then a fused one.
  for (const CalibrationSample& next :
       {Draw(&rng, Covariance(10, 0.01, 0.02), "zoomed-2", 1100.0),
        Draw(&rng, Covariance(10, 0.01, 0.02), "zoomed-3", 1100.0)}) {
    std::string reason_original, reason_restored;
    const FusionOutcome outcome = original.Add(next, &reason_original);
    EXPECT_EQ(restored.Add(next, &reason_restored), outcome);
    EXPECT_EQ(reason_restored, reason_original);
    EXPECT_EQ(Estimate(restored), Estimate(original));
    EXPECT_EQ(restored.covariance(), original.covariance());
  }
  EXPECT_EQ(restored.ToJson(), original.ToJson());
  const CalibrationFusion empty = CalibrationFusion::FromJson(CalibrationFusion().ToJson());
  EXPECT_TRUE(empty.empty());
  EXPECT_TRUE(CalibrationFusion().ToJson()["camera"].is_null());
}

TEST(CalibrationFusionJson, DamagedStateThrowsNamingTheField) {
  std::mt19937 rng(23);
  const nlohmann::json good = Eventful(&rng).ToJson();
  const auto expect_damaged = [&](const std::function<void(nlohmann::json&)>& damage,
                                  const std::string& named) {
    nlohmann::json j = good;
    damage(j);
    try {
      CalibrationFusion::FromJson(j);
      ADD_FAILURE() << "accepted damage to " << named;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(named), std::string::npos) << e.what();
    }
  };
  expect_damaged([](nlohmann::json& j) { j.erase("information_matrix"); },
                 "'information_matrix' is missing");
  expect_damaged([](nlohmann::json& j) { j["bursts"] = "five"; }, "'bursts' is not an integer");
  expect_damaged([](nlohmann::json& j) { j["information_matrix"][1][1] = -1.0; },
                 "'information_matrix' is not symmetric positive definite");
  expect_damaged([](nlohmann::json& j) { j["information_matrix"][0][2] = 0.5; },
                 "'information_matrix' is not symmetric positive definite");
  expect_damaged([](nlohmann::json& j) { j["information_vector"][2] = "x"; },
                 "'information_vector[2]' is not a finite number");
  expect_damaged(
      [](nlohmann::json& j) {
        j["information_matrix"] = {1, 2, 3};
      },
      "'information_matrix[0]' is not an array of 3 numbers");
  expect_damaged([](nlohmann::json& j) { j["geometry"].erase("cy"); }, "'geometry.cy' is missing");
  expect_damaged([](nlohmann::json& j) { j["pending_outlier"]["camera"]["fx"] = -3.0; },
                 "'pending_outlier.camera'");
  expect_damaged([](nlohmann::json& j) { j["history"][1]["outcome"] = "exploded"; },
                 "'history[1].outcome' is not an outcome name");
  expect_damaged([](nlohmann::json& j) { j["history"][0]["chi2"] = "high"; },
                 "'history[0].chi2' is not a number");
  expect_damaged([](nlohmann::json& j) { j["counts"] = 7; }, "'counts' is not an object");
  expect_damaged([](nlohmann::json& j) { j["version"] = 2; }, "'version' is not 1");
  expect_damaged([](nlohmann::json& j) { j = nlohmann::json::array(); }, "not a JSON object");
  expect_damaged(
      [](nlohmann::json& j) {
        j["bursts"] = 0;
        j["pending_outlier"] = nullptr;
      },
      "'information_matrix' is not zero");
}

}  // namespace
}  // namespace dfsm
