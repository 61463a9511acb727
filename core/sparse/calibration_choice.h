// One camera's bursts answer "what is this camera" twice: the joint
// adjustment (their tracks in one problem, core/sparse/joint_adjustment.h)
// and the fusion of the bursts' own debiased estimates
// (core/sparse/calibration_fusion.h). Where most bursts observe f alone on a
// hand's path, the fusion is the nearer (its bursts' cameras were found with
// each frame's angular velocity, the joint problem's on the line); where they
// do not, only the joint adjustment answers; and only it tells the bursts of
// another camera apart (docs/experiments/034-joint-own-minimum.md). This
// picks the answer to give.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>

#include "core/camera/camera_model.h"

namespace dfsm {

class CalibrationFusion;
struct JointCalibration;

enum class CalibrationAnswer { kJoint, kFused };
const char* CalibrationAnswerName(CalibrationAnswer answer);  // "joint" | "fused"

// One answer's focal length and how far it is sure of it.
struct FocalAnswer {
  double f = 0.0;
  double sigma_f_percent = 0.0;  // 0: no uncertainty
  bool degenerate = false;       // its verdict
  int bursts = 0;                // the bursts it is made of
};

struct CalibrationChoiceOptions {
  // The two answers agree where their focal lengths differ by at most this
  // many of their sigmas combined; where they do not, the joint one stands
  // (the fusion may have restarted on another camera's bursts).
  double max_disagreement_sigma = 2.0;
  // A fusion of fewer bursts does not answer.
  int min_fused_bursts = 2;
  // Throws std::invalid_argument naming the option out of its range.
  void Check() const;
};

struct CalibrationChoice {
  CalibrationAnswer answer = CalibrationAnswer::kJoint;
  std::string reason;  // a sentence: why this one
};

// The joint answer, unless the fusion agrees with it and either is the more
// certain or the joint one is degenerate or has no sigma.
CalibrationChoice ChooseCalibration(const FocalAnswer& joint,
                                    const std::optional<FocalAnswer>& fused,
                                    const CalibrationChoiceOptions& options = {});

// The answer chosen between a joint calibration and the fusion of the same
// bursts: the camera to write and to give as a prior, with its sigmas.
struct Answer {
  CalibrationChoice choice;
  CameraModel camera;
  double sigma_f_percent = 0.0;  // 0: none
  double distortion_sigma_px = 0.0;
  int bursts = 0;
};

// `joint` or `fusion` (empty: none), as ChooseCalibration picks.
Answer ChooseAnswer(const JointCalibration& joint, const CalibrationFusion& fusion,
                    const CalibrationChoiceOptions& options = {});

// joint.json's "answer": method ("joint" | "fused"), reason, camera,
// sigma_f_percent, distortion_sigma_px, bursts (JointCalibrationPrior reads
// it).
nlohmann::json ToJson(const Answer& answer);

}  // namespace dfsm
