#include "core/sparse/calibration_choice.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/sparse/calibration_fusion.h"
#include "core/sparse/fixed_text.h"
#include "core/sparse/joint_adjustment.h"

namespace dfsm {

const char* CalibrationAnswerName(CalibrationAnswer answer) {
  return answer == CalibrationAnswer::kFused ? "fused" : "joint";
}

void CalibrationChoiceOptions::Check() const {
  if (!(max_disagreement_sigma > 0.0))
    throw std::invalid_argument("max_disagreement_sigma must be > 0, got " +
                                FixedText(max_disagreement_sigma));
  if (min_fused_bursts < 1)
    throw std::invalid_argument("min_fused_bursts must be >= 1, got " +
                                std::to_string(min_fused_bursts));
}

CalibrationChoice ChooseCalibration(const FocalAnswer& joint,
                                    const std::optional<FocalAnswer>& fused,
                                    const CalibrationChoiceOptions& options) {
  options.Check();
  if (!fused || fused->bursts < options.min_fused_bursts)
    return {CalibrationAnswer::kJoint, "no fusion of " + std::to_string(options.min_fused_bursts) +
                                           " or more bursts to compare"};
  if (!(fused->sigma_f_percent > 0.0))
    return {CalibrationAnswer::kJoint, "the fusion has no sigma to compare"};
  // A joint camera without a sigma is compared by the fusion's alone.
  const bool joint_sigma = joint.sigma_f_percent > 0.0;
  const double sigma_px = std::hypot(joint_sigma ? joint.sigma_f_percent / 100.0 * joint.f : 0.0,
                                     fused->sigma_f_percent / 100.0 * fused->f);
  const double apart = std::abs(joint.f - fused->f) / sigma_px;
  const std::string fusion = "the fusion of " + std::to_string(fused->bursts) + " bursts (f " +
                             FixedText(fused->f) + " px, sigma " +
                             FixedText(fused->sigma_f_percent) + " %)";
  if (!(apart <= options.max_disagreement_sigma))
    return {CalibrationAnswer::kJoint,
            fusion + " is " + FixedText(apart) +
                " sigma from the joint camera: another camera among the bursts?"};
  if (joint.degenerate || !joint_sigma)
    return {CalibrationAnswer::kFused, std::string("the joint camera is ") +
                                           (joint.degenerate ? "degenerate" : "without a sigma") +
                                           ", and " + fusion + " agrees with it"};
  if (fused->sigma_f_percent < joint.sigma_f_percent)
    return {CalibrationAnswer::kFused,
            fusion + " agrees with the joint camera and is the more certain"};
  return {CalibrationAnswer::kJoint, "the joint camera is the more certain; " + fusion + " agrees"};
}

Answer ChooseAnswer(const JointCalibration& joint, const CalibrationFusion& fusion,
                    const CalibrationChoiceOptions& options) {
  Answer answer;
  answer.camera = joint.camera;
  answer.sigma_f_percent =
      joint.uncertainty.available ? joint.uncertainty.sigma_f_percent(joint.camera.f) : 0.0;
  answer.distortion_sigma_px = joint.uncertainty.distortion_sigma_px;
  answer.bursts = joint.Joined();
  const FocalAnswer joint_answer{answer.camera.f, answer.sigma_f_percent,
                                 joint.verdict.quality == CalibrationQuality::kDegenerate,
                                 answer.bursts};
  std::optional<FocalAnswer> fused;
  if (!fusion.empty())
    fused = FocalAnswer{fusion.camera().f, fusion.sigma_f_percent(), false, fusion.bursts()};
  answer.choice = ChooseCalibration(joint_answer, fused, options);
  if (answer.choice.answer == CalibrationAnswer::kFused) {
    answer.camera = fusion.camera();
    answer.sigma_f_percent = fusion.sigma_f_percent();
    answer.distortion_sigma_px = fusion.distortion_sigma_px();
    answer.bursts = fusion.bursts();
  }
  return answer;
}

nlohmann::json ToJson(const Answer& answer) {
  return {{"method", CalibrationAnswerName(answer.choice.answer)},
          {"reason", answer.choice.reason},
          {"camera", ToJson(answer.camera)},
          {"sigma_f_percent", answer.sigma_f_percent},
          {"distortion_sigma_px", answer.distortion_sigma_px},
          {"bursts", answer.bursts}};
}

}  // namespace dfsm
