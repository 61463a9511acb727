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
    throw std::invalid_argument("max_disagreement_sigma must be > 0");
  if (min_fused_bursts < 1) throw std::invalid_argument("min_fused_bursts must be >= 1");
}

CalibrationChoice ChooseCalibration(const FocalAnswer& joint,
                                    const std::optional<FocalAnswer>& fused,
                                    const CalibrationChoiceOptions& options) {
  options.Check();
  if (!fused || fused->bursts < options.min_fused_bursts || !(fused->sigma_f_percent > 0.0))
    return {CalibrationAnswer::kJoint, "no fusion of " + std::to_string(options.min_fused_bursts) +
                                           " or more bursts to compare"};
  const double sigma_px = std::hypot(joint.sigma_f_percent / 100.0 * joint.f,
                                     fused->sigma_f_percent / 100.0 * fused->f);
  const double apart = std::abs(joint.f - fused->f) / sigma_px;
  const std::string fusion = "the fusion of " + std::to_string(fused->bursts) + " bursts (f " +
                             FixedText(fused->f) + " px, sigma " +
                             FixedText(fused->sigma_f_percent) + " %)";
  if (!(apart <= options.max_disagreement_sigma))
    return {CalibrationAnswer::kJoint,
            fusion + " is " + FixedText(apart) +
                " sigma from the joint camera: another camera among the bursts?"};
  if (joint.degenerate)
    return {CalibrationAnswer::kFused,
            "the joint camera is degenerate, and " + fusion + " agrees with it"};
  if (fused->sigma_f_percent < joint.sigma_f_percent)
    return {CalibrationAnswer::kFused,
            fusion + " agrees with the joint camera and is the more certain"};
  return {CalibrationAnswer::kJoint, "the joint camera is the more certain; " + fusion + " agrees"};
}

nlohmann::json AnswerJson(const JointCalibration& joint, const CalibrationFusion& fusion,
                          const CalibrationChoiceOptions& options) {
  FocalAnswer joint_answer;
  joint_answer.f = joint.camera.f;
  joint_answer.sigma_f_percent =
      joint.uncertainty.available ? joint.uncertainty.sigma_f_percent(joint.camera.f) : 0.0;
  joint_answer.degenerate = joint.verdict.quality == CalibrationQuality::kDegenerate;
  joint_answer.bursts = joint.Joined();
  std::optional<FocalAnswer> fused;
  if (!fusion.empty())
    fused = FocalAnswer{fusion.camera().f, fusion.sigma_f_percent(), false, fusion.bursts()};
  const CalibrationChoice choice = ChooseCalibration(joint_answer, fused, options);
  nlohmann::json answer = {{"method", CalibrationAnswerName(choice.answer)},
                           {"reason", choice.reason}};
  if (choice.answer == CalibrationAnswer::kFused) {
    answer["camera"] = ToJson(fusion.camera());
    answer["sigma_f_percent"] = fusion.sigma_f_percent();
    answer["distortion_sigma_px"] = fusion.distortion_sigma_px();
    answer["bursts"] = fusion.bursts();
  } else {
    answer["camera"] = ToJson(joint.camera);
    answer["sigma_f_percent"] = joint_answer.sigma_f_percent;
    answer["distortion_sigma_px"] = joint.uncertainty.distortion_sigma_px;
    answer["bursts"] = joint_answer.bursts;
  }
  return answer;
}

CameraModel AnsweredCamera(const nlohmann::json& joint) {
  if (joint.contains("answer")) return CameraModelFromJson(joint.at("answer").at("camera"));
  return CameraModelFromJson(joint.at("camera"));
}

}  // namespace dfsm
