#include "core/sparse/calibration_choice.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace dfsm {
namespace {

FocalAnswer Answer(double f, double sigma_f_percent, int bursts, bool degenerate = false) {
  FocalAnswer answer;
  answer.f = f;
  answer.sigma_f_percent = sigma_f_percent;
  answer.bursts = bursts;
  answer.degenerate = degenerate;
  return answer;
}

// Within their combined sigma the two agree, and the more certain answers.
TEST(ChooseCalibration, TheMoreCertainOfTwoThatAgreeAnswers) {
  const CalibrationChoice fused = ChooseCalibration(Answer(730.0, 5.0, 5), Answer(705.0, 1.5, 5));
  EXPECT_EQ(fused.answer, CalibrationAnswer::kFused) << fused.reason;
  EXPECT_NE(fused.reason.find("more certain"), std::string::npos) << fused.reason;
  const CalibrationChoice joint = ChooseCalibration(Answer(705.0, 1.0, 5), Answer(712.0, 2.0, 3));
  EXPECT_EQ(joint.answer, CalibrationAnswer::kJoint) << joint.reason;
}

// A fusion far from the joint camera (a restart on another camera's bursts)
// never answers, however certain it says it is.
TEST(ChooseCalibration, AFusionThatDisagreesNeverAnswers) {
  const CalibrationChoice choice = ChooseCalibration(Answer(720.0, 6.0, 5), Answer(555.0, 2.6, 3));
  EXPECT_EQ(choice.answer, CalibrationAnswer::kJoint);
  EXPECT_NE(choice.reason.find("another camera"), std::string::npos) << choice.reason;
}

// A degenerate joint camera gives way to a fusion that agrees with it, even a
// less certain one; without a fusion of two bursts the joint one answers.
TEST(ChooseCalibration, ADegenerateJointCameraGivesWayToAFusionThatAgrees) {
  const CalibrationChoice fused =
      ChooseCalibration(Answer(600.0, 11.0, 10, true), Answer(516.0, 12.0, 4));
  EXPECT_EQ(fused.answer, CalibrationAnswer::kFused) << fused.reason;
  EXPECT_EQ(ChooseCalibration(Answer(600.0, 11.0, 10, true), std::nullopt).answer,
            CalibrationAnswer::kJoint);
  EXPECT_EQ(ChooseCalibration(Answer(600.0, 11.0, 10, true), Answer(516.0, 1.0, 1)).answer,
            CalibrationAnswer::kJoint);
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
