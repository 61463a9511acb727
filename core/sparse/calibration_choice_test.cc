#include "core/sparse/calibration_choice.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/sparse/calibration_fusion.h"
#include "core/sparse/joint_adjustment.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {
namespace {

FocalAnswer Focal(double f, double sigma_f_percent, int bursts, bool degenerate = false) {
  FocalAnswer answer;
  answer.f = f;
  answer.sigma_f_percent = sigma_f_percent;
  answer.bursts = bursts;
  answer.degenerate = degenerate;
  return answer;
}

// Within their combined sigma the two agree, and the more certain answers.
TEST(ChooseCalibration, TheMoreCertainOfTwoThatAgreeAnswers) {
  const CalibrationChoice fused = ChooseCalibration(Focal(730.0, 5.0, 5), Focal(705.0, 1.5, 5));
  EXPECT_EQ(fused.answer, CalibrationAnswer::kFused) << fused.reason;
  EXPECT_NE(fused.reason.find("more certain"), std::string::npos) << fused.reason;
  const CalibrationChoice joint = ChooseCalibration(Focal(705.0, 1.0, 5), Focal(712.0, 2.0, 3));
  EXPECT_EQ(joint.answer, CalibrationAnswer::kJoint) << joint.reason;
}

// A fusion far from the joint camera (a restart on another camera's bursts)
// never answers, however certain it says it is.
TEST(ChooseCalibration, AFusionThatDisagreesNeverAnswers) {
  const CalibrationChoice choice = ChooseCalibration(Focal(720.0, 6.0, 5), Focal(555.0, 2.6, 3));
  EXPECT_EQ(choice.answer, CalibrationAnswer::kJoint);
  EXPECT_NE(choice.reason.find("another camera"), std::string::npos) << choice.reason;
}

// A degenerate joint camera gives way to a fusion that agrees with it, even a
// less certain one; without a fusion of two bursts the joint one answers.
TEST(ChooseCalibration, ADegenerateJointCameraGivesWayToAFusionThatAgrees) {
  const CalibrationChoice fused =
      ChooseCalibration(Focal(600.0, 11.0, 10, true), Focal(516.0, 12.0, 4));
  EXPECT_EQ(fused.answer, CalibrationAnswer::kFused) << fused.reason;
  EXPECT_EQ(ChooseCalibration(Focal(600.0, 11.0, 10, true), std::nullopt).answer,
            CalibrationAnswer::kJoint);
  EXPECT_EQ(ChooseCalibration(Focal(600.0, 11.0, 10, true), Focal(516.0, 1.0, 1)).answer,
            CalibrationAnswer::kJoint);
}

// A joint camera without a sigma is compared by the fusion's sigma alone.
TEST(ChooseCalibration, AJointCameraWithoutASigmaGivesWayToAFusionThatAgrees) {
  const CalibrationChoice choice = ChooseCalibration(Focal(720.0, 0.0, 5), Focal(705.0, 2.0, 4));
  EXPECT_EQ(choice.answer, CalibrationAnswer::kFused) << choice.reason;
  EXPECT_NE(choice.reason.find("without a sigma"), std::string::npos) << choice.reason;
  EXPECT_EQ(ChooseCalibration(Focal(800.0, 0.0, 5), Focal(705.0, 2.0, 4)).answer,
            CalibrationAnswer::kJoint);
}

CameraModel Camera(double f, double k1) {
  CameraModel camera;
  camera.width = 640;
  camera.height = 480;
  camera.cx = 320.0;
  camera.cy = 240.0;
  camera.f = f;
  camera.k1 = k1;
  camera.k2 = 0.02;
  return camera;
}

CalibrationSample Sample(double f, const std::string& job) {
  CalibrationSample sample;
  sample.camera = Camera(f, -0.06);
  const Eigen::Vector3d sigma(0.02 * f, 0.01, 0.02);
  sample.covariance = sigma.cwiseAbs2().asDiagonal();
  sample.job = job;
  return sample;
}

// A degenerate joint camera (no uncertainty) beside a fusion of two bursts
// that agrees: the answer is the fusion's camera with its sigmas, and
// joint.json's "answer" makes it the prior of a later burst; a joint.json
// without one (an older file) gives the joint camera's prior as before,
// none where it is degenerate.
TEST(ChooseAnswer, TheFusedAnswerIsTheCameraWrittenAndThePriorGiven) {
  JointCalibration joint;
  joint.camera = Camera(712.0, -0.2);
  joint.verdict.quality = CalibrationQuality::kDegenerate;
  CalibrationFusion fusion;
  fusion.Add(Sample(700.0, "a"));
  fusion.Add(Sample(708.0, "b"));
  const Answer answer = ChooseAnswer(joint, fusion);
  ASSERT_EQ(answer.choice.answer, CalibrationAnswer::kFused) << answer.choice.reason;
  EXPECT_DOUBLE_EQ(answer.camera.f, fusion.camera().f);
  EXPECT_DOUBLE_EQ(answer.sigma_f_percent, fusion.sigma_f_percent());
  EXPECT_EQ(answer.bursts, 2);

  nlohmann::json stored = {{"camera", ToJson(joint.camera)},
                           {"uncertainty", {{"available", false}}},
                           {"verdict", {{"quality", "degenerate"}}},
                           {"bursts_joined", 3}};
  std::string why;
  EXPECT_FALSE(JointCalibrationPrior(stored, &why).has_value());
  EXPECT_NE(why.find("degenerate"), std::string::npos) << why;
  stored["answer"] = ToJson(answer);
  const std::optional<KnownCalibration> prior = JointCalibrationPrior(stored, &why);
  ASSERT_TRUE(prior.has_value()) << why;
  EXPECT_DOUBLE_EQ(prior->camera.f, fusion.camera().f);
  EXPECT_NEAR(prior->f_sigma_percent, fusion.sigma_f_percent(), 1e-9);
  EXPECT_TRUE(prior->check_fit);
  EXPECT_EQ(prior->source.rfind("fused (2 bursts", 0), 0u) << prior->source;
}

TEST(CalibrationChoiceOptions, AnOptionOutOfItsRangeIsRefusedByName) {
  CalibrationChoiceOptions options;
  options.max_disagreement_sigma = 0.0;
  EXPECT_THROW(
      {
        try {
          options.Check();
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("max_disagreement_sigma"), std::string::npos);
          throw;
        }
      },
      std::invalid_argument);
  options = {};
  options.min_fused_bursts = 0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
