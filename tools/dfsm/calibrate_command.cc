// dfsm calibrate BURST... --out DIR: the calibration of one camera from several
// of its bursts. Each burst's sparse stage runs alone first (its tracks, its
// own solution, its own verdict); then either the joint adjustment
// (core/sparse/joint_adjustment.h, the default: the camera shared by one
// problem over every burst's tracks, which a burst too weak to calibrate alone
// still informs; the camera written is the joint one or the fusion of the
// same bursts, as core/sparse/calibration_choice.h picks) or the fusion dfsmd
// keeps over days (core/sparse/calibration_fusion.h: each usable burst's
// estimate weighed by its information).
#include <unistd.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>

#include "core/export/calibration_export.h"
#include "core/io/file_util.h"
#include "core/sparse/calibration_choice.h"
#include "core/sparse/calibration_fusion.h"
#include "core/sparse/joint_adjustment.h"
#include "core/sparse/sparse_reconstruction.h"
#include "tools/dfsm/batch_calibration.h"
#include "tools/dfsm/burst_input.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"

namespace dfsm::tools {
namespace {

enum class CalibrateMethod { kJoint, kFusion };

struct CalibrateInputs {
  std::vector<BatchItem> bursts;  // each named by its input (and window)
  std::filesystem::path out_dir;
  int frames = 0;            // of each burst (0: all), as --frames
  PipelineOptions pipeline;  // its sparse stage: each burst's own calibration
};

// One burst's sparse stage, alone; nullopt where it fails, with why. Prints
// the burst's own calibration (the line the caller ends).
std::optional<SparseReconstruction> CalibrateAlone(const BatchItem& item,
                                                   const CalibrateInputs& inputs,
                                                   std::string* failure) {
  const char* burst_dir = item.name.c_str();
  try {
    const std::filesystem::path scratch =
        inputs.out_dir / (".burst-" + std::to_string(getpid()));  // a tar's files
    SparseReconstruction sparse = ReconstructAlone(item, inputs.frames, inputs.pipeline, scratch);
    const CameraModel& camera = sparse.state.camera;
    std::printf("%s: f %.2f px (sigma %.2f %%), k1 %.5f, k2 %.5f, %s", burst_dir, camera.f,
                sparse.uncertainty.available ? sparse.uncertainty.sigma_f_percent(camera.f) : 0.0,
                camera.k1, camera.k2, CalibrationQualityName(sparse.verdict.quality));
    return sparse;
  } catch (const BurstError& e) {
    std::printf("%s: unreadable", burst_dir);
    *failure = e.what();
  } catch (const ReconstructionError& e) {
    std::printf("%s: failed", burst_dir);
    *failure = e.what();
  }
  return std::nullopt;
}

int RunFusion(const CalibrateInputs& inputs) {
  CalibrationFusion fusion;
  for (const BatchItem& item : inputs.bursts) {
    const std::string& burst_dir = item.name;
    std::string outcome;
    const std::optional<SparseReconstruction> sparse = CalibrateAlone(item, inputs, &outcome);
    if (!sparse) {
      outcome = "not fused: " + outcome;
    } else if (const std::optional<CalibrationSample> sample =
                   FusionSampleOf(*sparse, burst_dir, &outcome)) {
      if (sample->camera.f != sparse->state.camera.f)
        std::printf(", less its noise bias f %.2f px", sample->camera.f);
      std::string reason;
      outcome = FusionOutcomeName(fusion.Add(*sample, &reason));
      if (!reason.empty()) outcome += ": " + reason;
    } else {
      outcome = "not fused: " + outcome;
    }
    std::printf(" -> %s\n", outcome.c_str());
  }
  if (fusion.empty()) {
    std::fprintf(stderr, "dfsm calibrate: no burst could be fused\n");
    return 1;
  }
  std::filesystem::create_directories(inputs.out_dir);
  WriteCalibrationFiles(inputs.out_dir, fusion.camera());
  WriteFileAtomically(inputs.out_dir / "fusion.json", fusion.ToJson().dump(2) + "\n");
  const CameraModel fused = fusion.camera();
  std::printf(
      "fused       f %.2f px (sigma %.2f %%), k1 %.5f, k2 %.5f, distortion sigma %.2f px, "
      "%d bursts, %s\n",
      fused.f, fusion.sigma_f_percent(), fused.k1, fused.k2, fusion.distortion_sigma_px(),
      fusion.bursts(), fusion.reliable() ? "reliable" : "not yet reliable");
  return 0;
}

// A burst's entry of joint.json before the joint adjustment: its own
// calibration, or why it could not take part.
nlohmann::json OwnCalibrationJson(const std::string& burst_dir, const SparseReconstruction* sparse,
                                  const std::string& failure) {
  nlohmann::json entry = {{"name", burst_dir}};
  if (!sparse) {
    entry["outcome"] = "failed";
    entry["reason"] = failure;
    return entry;
  }
  const CameraModel& camera = sparse->state.camera;
  entry["own"] = {{"camera", ToJson(camera)},
                  {"uncertainty", ToJson(sparse->uncertainty, camera.f)},
                  {"verdict", ToJson(sparse->verdict)},
                  {"tracks", CountUsed(sparse->inliers)}};
  entry["frames"] = sparse->feature_stats.kept_frames;
  return entry;
}

void PrintJoint(const JointCalibration& joint, const std::vector<JointBurst>& bursts) {
  for (size_t k = 0; k < bursts.size(); ++k)
    std::printf("%s: %s (disagreement %.1f)\n", bursts[k].name.c_str(),
                JointOutcomeName(joint.bursts[k].outcome), joint.bursts[k].disagreement);
  const CameraModel& camera = joint.camera;
  std::printf(
      "joint       f %.2f px (sigma %.2f %%), k1 %.5f, k2 %.5f, distortion sigma %.2f px, "
      "%d of %zu bursts, %s\n",
      camera.f, joint.uncertainty.available ? joint.uncertainty.sigma_f_percent(camera.f) : 0.0,
      camera.k1, camera.k2, joint.uncertainty.distortion_sigma_px, joint.Joined(), bursts.size(),
      CalibrationQualityName(joint.verdict.quality));
  for (const std::string& reason : joint.verdict.reasons)
    std::printf("            %s\n", reason.c_str());
}

void PrintAnswer(const Answer& answer) {
  std::printf("answer      %s: f %.2f px (sigma %.2f %%), k1 %.5f, k2 %.5f; %s\n",
              CalibrationAnswerName(answer.choice.answer), answer.camera.f, answer.sigma_f_percent,
              answer.camera.k1, answer.camera.k2, answer.choice.reason.c_str());
}

// joint.json: the joint calibration, each burst's entry with its own
// calibration beside its part in the joint one.
nlohmann::json JointJson(const JointCalibration& joint, const std::vector<JointBurst>& bursts,
                         std::vector<nlohmann::json> entries, const std::vector<int>& entry_of) {
  nlohmann::json json = ToJson(joint, bursts);
  for (size_t k = 0; k < bursts.size(); ++k) entries[entry_of[k]].update(json["bursts"][k]);
  json["bursts"] = std::move(entries);
  return json;
}

int RunJoint(const CalibrateInputs& inputs) {
  std::vector<JointBurst> bursts;
  // Beside the joint adjustment, the fusion of the bursts' own estimates:
  // the answer is the one of the two that calibration_choice.h picks.
  CalibrationFusion fusion;
  std::vector<nlohmann::json> entries;
  std::vector<int> entry_of;  // each joint burst's entry
  for (const BatchItem& item : inputs.bursts) {
    const std::string& burst_dir = item.name;
    std::string failure;
    const std::optional<SparseReconstruction> sparse = CalibrateAlone(item, inputs, &failure);
    // Its tracks only are kept: memory stays one burst's frames at a time.
    entries.push_back(OwnCalibrationJson(burst_dir, sparse ? &*sparse : nullptr, failure));
    const bool joins = sparse && sparse->OwnCamera();
    if (!sparse) {
      std::printf(" -> not joined: %s\n", failure.c_str());
    } else if (!joins) {
      std::printf(" -> not joined: no calibration of its own (%s)\n",
                  CalibrationSourceName(sparse->calibration_used));
    } else if (sparse->calibration_used != CalibrationSource::kSelf) {
      // A fallback's camera is not the burst's estimate: its tracks join
      // with the camera it estimated.
      std::printf(" (%s)\n", CalibrationSourceName(sparse->calibration_used));
    } else {
      std::printf("\n");
    }
    if (!joins) continue;
    entry_of.push_back(static_cast<int>(entries.size()) - 1);
    bursts.push_back(JointBurstOf(burst_dir, *sparse));
    std::string not_fused;
    if (const std::optional<CalibrationSample> sample =
            FusionSampleOf(*sparse, burst_dir, &not_fused))
      fusion.Add(*sample);
  }
  if (bursts.empty()) {
    std::fprintf(stderr, "dfsm calibrate: no burst could be read and reconstructed\n");
    return 1;
  }
  JointCalibration joint;
  try {
    joint = AdjustJointly(bursts, JointOptionsFor(inputs.pipeline.sparse));
  } catch (const ReconstructionError& e) {
    std::fprintf(stderr, "dfsm calibrate: %s\n", e.what());
    return 1;
  }
  PrintJoint(joint, bursts);
  const Answer answer = ChooseAnswer(joint, fusion);
  PrintAnswer(answer);
  nlohmann::json json = JointJson(joint, bursts, std::move(entries), entry_of);
  json["answer"] = ToJson(answer);
  std::filesystem::create_directories(inputs.out_dir);
  WriteCalibrationFiles(inputs.out_dir, answer.camera);
  WriteFileAtomically(inputs.out_dir / "joint.json", json.dump(2) + "\n");
  return 0;
}

}  // namespace

int RunCalibrateCommand(const Args& args) {
  CLI::App app("Calibrates one camera from several of its bursts.", "dfsm calibrate");
  app.footer(
      "Bursts must share one image size. Exit status: 0 a calibration was written, 1 none could "
      "be made (no burst usable, or fewer than two agreeing), 2 usage.");
  CalibrateInputs inputs;
  std::vector<std::string> bursts;
  int window_frames = 0;
  std::string out_dir, rolling_shutter = kDefaultRollingShutter, method = "joint";
  app.add_option("BURST", bursts,
                 "bursts of one camera: dfsm-burst/1 directories, burst.tar files (as dfsmd "
                 "serves them), videos, folders of PNG or JPEG images or globs of them "
                 "('clip/*.jpg', quoted)")
      ->required();
  app.add_option("--out", out_dir,
                 "written: calibration.json and calibration.yaml of the camera (as 'dfsm process' "
                 "writes them) and joint.json (the shared camera with its sigma and verdict, "
                 "each burst's own calibration, outcome and poses, and the answer: the joint "
                 "camera, or the fusion of the same bursts where it agrees and is the more "
                 "certain or the joint camera is degenerate) or, with --method fusion, "
                 "fusion.json")
      ->required();
  app.add_option("--method", method,
                 "joint: one adjustment over every burst's tracks, the camera shared (bursts "
                 "that disagree with it are left out); fusion: each usable burst's estimate "
                 "weighed by its information, as dfsmd keeps it over days")
      ->check(CLI::IsMember({"joint", "fusion"}))
      ->capture_default_str();
  app.add_option("--frames", inputs.frames,
                 "use N frames of each burst, centred on its reference (0: all)")
      ->check(FrameCount());
  app.add_option("--windows", window_frames,
                 "cut each video, folder or glob of images into consecutive bursts of N frames "
                 "(a clip's frames; 0: each one burst)")
      ->check(FrameCount());
  app.add_option("--rolling-shutter", rolling_shutter,
                 "global | estimate | R: the sensor's readout, as for 'dfsm process'")
      ->capture_default_str();
  if (const auto status = ParseCommandLine(app, args)) return *status;
  inputs.out_dir = out_dir;
  for (const std::string& burst : bursts) {
    try {
      for (const BurstWindow& window : WindowsOf(burst, window_frames)) {
        BatchItem item;
        item.name = window.Name();
        item.input = window.input;
        item.tar = IsTarFile(window.input);
        item.start = window.start;
        item.frames = window.frames;
        inputs.bursts.push_back(std::move(item));
      }
    } catch (const BurstError& e) {
      throw UsageError(e.what());
    }
  }
  try {
    inputs.pipeline.sparse.rolling_shutter = ParseRollingShutter(rolling_shutter);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--rolling-shutter: ") + e.what());
  }
  return method == "joint" ? RunJoint(inputs) : RunFusion(inputs);
}

}  // namespace dfsm::tools
