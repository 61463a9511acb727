// One camera's bursts calibrated three ways, side by side: each alone, fused
// by information weight (core/sparse/calibration_fusion.h, as dfsmd keeps its
// camera) and adjusted jointly (core/sparse/joint_adjustment.h, dfsm
// calibrate's default), then the answer dfsm calibrate writes of the two
// (core/sparse/calibration_choice.h). One JSON line per burst, then one per
// method, each scored against the true camera.
//   joint_calibration --dataset DIR [--start K] [--step S] [--frames N]
//                     [--windows W] [--downscale D] [--calibration FILE]
//                     [--consistency P] [--pinned-depth on|off]
//       windows of a TUM sequence (as tum_benchmark reads them), scored
//       against the published calibration;
//   joint_calibration --sequence DIR [--start K] [--step S] [--frames N]
//                     [--windows W]
//       windows of a folder (or glob) of images, the first of each its
//       reference (a real clip without ground truth: not scored);
//   joint_calibration BURST...
//       dfsm-burst/1 directories with ground_truth.json (dfsm synth writes
//       them), scored against each one's camera (the first burst's for the
//       fused and joint ones).
// --windows W: at most the first W windows (issue 54's split of one clip into
// halves: --windows 4, then --start at the fifth window's first frame).
// --consistency P: JointAdjustmentOptions::consistency_probability.
// --pinned-depth on: each window's (or burst's) tracks also pinned to the
// Kinect's depth or the generator's (bench/pinned_depth.h), and those bursts
// adjusted jointly with their inverse depths held: the shared camera the
// tracks choose once every burst's depths are right, the joint problem's
// oracle, with its noise bias (which the poses still give) and the camera
// less it (docs/experiments/045-the-joint-camera-at-true-depths.md).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "bench/pinned_depth.h"
#include "bench/report_options.h"
#include "bench/tum_sequence.h"
#include "core/io/ground_truth.h"
#include "core/io/image_sequence.h"
#include "core/pipeline/pipeline.h"
#include "core/sparse/calibration_choice.h"
#include "core/sparse/calibration_fusion.h"
#include "core/sparse/joint_adjustment.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {
namespace {

double Milliseconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since)
      .count();
}

double FocalErrorPercent(const CameraModel& camera, const CameraModel& truth) {
  return 100.0 * (camera.f - truth.f) / truth.f;
}

struct Input {
  std::string name;
  std::function<Burst()> read;
  std::optional<CameraModel> truth;      // none: not scored
  std::function<cv::Mat()> truth_depth;  // the reference's, in metres; none: not pinned
};

// The scores of `camera` against `truth`, where there is one.
void Score(const CameraModel& camera, const std::optional<CameraModel>& truth,
           nlohmann::json* line) {
  if (!truth) return;
  (*line)["f_error_percent"] = FocalErrorPercent(camera, *truth);
  (*line)["distortion_error_px"] = MeanDistortionError(camera, *truth);
}

// Burst `input`, whose sparse stage is `sparse`, with its tracks pinned to its
// true depth: the tracks that could be pinned, under the camera they choose
// there (its own minimum at those depths). nullopt, with why in `line`, where
// too few could be pinned or the pinning failed (the dense stage cannot
// invert the burst's own camera).
std::optional<JointBurst> PinnedJointBurst(const Input& input, const Burst& burst,
                                           const SparseReconstruction& sparse,
                                           const PipelineOptions& options, nlohmann::json* line) {
  std::optional<PinnedDepth> pinned;
  try {
    pinned = PinDepthToTruth(burst, input.truth_depth(), cv::Mat(), sparse, options.sparse,
                             options.dense);
  } catch (const std::exception& e) {
    (*line)["not_pinned"] = e.what();
    return std::nullopt;
  }
  if (!pinned) {
    (*line)["not_pinned"] = "too few tracks on flat truth";
    return std::nullopt;
  }
  JointBurst joint = JointBurstOf(input.name, sparse);
  joint.state = pinned->camera_at_truth;
  joint.use = pinned->pinned_tracks;
  (*line)["at_truth_f"] = joint.state.camera.f;
  (*line)["pinned_tracks"] = pinned->tracks();
  if (input.truth)
    (*line)["at_truth_f_error_percent"] = FocalErrorPercent(joint.state.camera, *input.truth);
  return joint;
}

// Replicas of the noise bias at the true depths: as many as the measurements
// of docs/experiments/045 used (antithetic pairs, bootstrap_bias.h).
constexpr int kReplicasAtTruth = 8;

// The noise bias of `joint`, adjusted from `pinned` under `held`, in percent
// of its f: the joined bursts' tracks replaced by ones its solution explains
// plus noise as large as their residuals, each replica adjusted jointly again
// with the depths held; the replicas' mean f less the solution's. The joint
// adjustment does not measure it itself where the depths are held: its
// bootstrap is gated by the covariance, which held depths do not give.
double NoiseBiasAtTruthPercent(const std::vector<JointBurst>& pinned,
                               const JointAdjustmentOptions& held, const JointCalibration& joint) {
  // The joined bursts at the solution, each with the tracks it explains and
  // its noise: every replica draws from these.
  std::vector<JointBurst> solved;
  std::vector<FeatureTracks> explained;
  std::vector<double> noise;
  for (size_t k = 0; k < pinned.size(); ++k) {
    if (joint.bursts[k].outcome != JointOutcome::kJoined) continue;
    JointBurst burst = pinned[k];
    burst.state.camera = joint.fitted_camera;
    burst.state.poses = joint.bursts[k].poses;
    burst.state.readout = joint.readout;
    burst.state.angular_velocities.clear();  // the joint problem's line
    explained.push_back(ExplainedTracks(burst.tracks, burst.use, burst.state));
    noise.push_back(ResidualNoisePx(burst.tracks, burst.use, burst.state, held.bundle_adjustment));
    solved.push_back(std::move(burst));
  }
  double sum = 0.0;
  for (int r = 0; r < kReplicasAtTruth; ++r) {
    std::vector<JointBurst> replica = solved;
    for (size_t b = 0; b < replica.size(); ++b)
      replica[b].tracks = ReplicaTracks(explained[b], replica[b].use, noise[b],
                                        held.bootstrap.seed + 104729 * b, r);
    sum += AdjustJointly(replica, held).fitted_camera.f;
  }
  const double f = joint.fitted_camera.f;
  return 100.0 * (sum / kReplicasAtTruth - f) / f;
}

// The joint adjustment of `pinned` with every inverse depth held: the shared
// camera the tracks choose at their true depths, and its noise bias (which
// the poses, still estimated per burst, give f even there).
void PrintJointAtTruth(const std::vector<JointBurst>& pinned, const PipelineOptions& options,
                       const std::optional<CameraModel>& truth) {
  nlohmann::json line = {{"method", "joint at the true depths"}, {"bursts", pinned.size()}};
  try {
    JointAdjustmentOptions held = JointOptionsFor(options.sparse);
    held.bundle_adjustment.hold_inverse_depths = true;
    const JointCalibration joint = AdjustJointly(pinned, held);
    line["f"] = joint.fitted_camera.f;
    line["k1"] = joint.fitted_camera.k1;
    line["k2"] = joint.fitted_camera.k2;
    Score(joint.fitted_camera, truth, &line);
    line["joined"] = joint.Joined();
    nlohmann::json left_out = nlohmann::json::array();
    for (size_t k = 0; k < pinned.size(); ++k)
      if (joint.bursts[k].outcome != JointOutcome::kJoined)
        left_out.push_back({{"burst", pinned[k].name}, {"tracks", CountUsed(pinned[k].use)}});
    line["left_out"] = left_out;
    line["readout"] = joint.readout;
    const double bias_percent = NoiseBiasAtTruthPercent(pinned, held, joint);
    line["bias_f_percent"] = bias_percent;
    if (truth) {
      CameraModel debiased = joint.fitted_camera;
      debiased.f *= 1.0 - bias_percent / 100.0;
      line["debiased_f_error_percent"] = FocalErrorPercent(debiased, *truth);
    }
  } catch (const std::exception& e) {
    line["failed"] = e.what();
  }
  std::printf("%s\n", line.dump().c_str());
}

int Run(const std::vector<Input>& inputs, double consistency_probability) {
  const PipelineOptions options;  // each burst's sparse stage as `dfsm process` runs it
  CalibrationFusion fusion;
  std::vector<JointBurst> bursts, pinned;
  double alone_ms = 0.0;
  for (const Input& input : inputs) {
    nlohmann::json line = {{"burst", input.name}};
    const auto start = std::chrono::steady_clock::now();
    try {
      const Burst burst = input.read();
      const SparseReconstruction sparse = ReconstructSparseStage(burst, options);
      const double ms = Milliseconds(start);
      alone_ms += ms;
      const CameraModel& camera = sparse.state.camera;
      line["f"] = camera.f;
      Score(camera, input.truth, &line);
      line["sigma_f_percent"] =
          sparse.uncertainty.available ? sparse.uncertainty.sigma_f_percent(camera.f) : -1.0;
      line["verdict"] = CalibrationQualityName(sparse.verdict.quality);
      line["tracks"] = CountUsed(sparse.inliers);
      line["readout"] = sparse.state.readout;
      line["k1"] = camera.k1;
      line["k2"] = camera.k2;
      line["sparse_ms"] = ms;
      std::string why;
      if (const std::optional<CalibrationSample> sample =
              FusionSampleOf(sparse, input.name, &why)) {
        std::string reason;
        line["fusion"] = FusionOutcomeName(fusion.Add(*sample, &reason));
      } else {
        line["fusion"] = "not fused: " + why;
      }
      bursts.push_back(JointBurstOf(input.name, sparse));
      if (input.truth_depth)
        if (std::optional<JointBurst> at_truth =
                PinnedJointBurst(input, burst, sparse, options, &line))
          pinned.push_back(std::move(*at_truth));
    } catch (const std::exception& e) {
      line["failed"] = e.what();
    }
    std::printf("%s\n", line.dump().c_str());
    std::fflush(stdout);
  }
  const std::optional<CameraModel>& truth = inputs.front().truth;
  nlohmann::json fused = {{"method", "fusion"}, {"bursts", inputs.size()}};
  if (fusion.empty()) {
    fused["failed"] = "no burst could be fused";
  } else {
    fused["f"] = fusion.camera().f;
    Score(fusion.camera(), truth, &fused);
    fused["sigma_f_percent"] = fusion.sigma_f_percent();
    fused["fused"] = fusion.bursts();
    fused["reliable"] = fusion.reliable();
  }
  std::printf("%s\n", fused.dump().c_str());
  nlohmann::json joint_line = {{"method", "joint"}, {"bursts", inputs.size()}};
  const auto start = std::chrono::steady_clock::now();
  nlohmann::json answer_line = {{"method", "answer"}};
  try {
    JointAdjustmentOptions joint_options = JointOptionsFor(options.sparse);
    if (consistency_probability > 0.0)
      joint_options.consistency_probability = consistency_probability;
    const JointCalibration joint = AdjustJointly(bursts, joint_options);
    joint_line["f"] = joint.camera.f;
    Score(joint.camera, truth, &joint_line);
    joint_line["sigma_f_percent"] =
        joint.uncertainty.available ? joint.uncertainty.sigma_f_percent(joint.camera.f) : -1.0;
    joint_line["distortion_sigma_px"] = joint.uncertainty.distortion_sigma_px;
    joint_line["verdict"] = ToJson(joint.verdict);
    joint_line["joined"] = joint.Joined();
    nlohmann::json disagreements = nlohmann::json::array();
    for (const JointBurstResult& result : joint.bursts)
      disagreements.push_back(result.disagreement);
    joint_line["disagreements"] = disagreements;
    joint_line["readout"] = joint.readout;
    joint_line["dispersion"] = joint.dispersion;
    joint_line["focal_dispersion"] = joint.focal_dispersion;
    joint_line["fitted_f"] = joint.fitted_camera.f;
    joint_line["bias_f"] = joint.bias ? joint.bias->f : 0.0;
    // The shared f's sigma from the tracks' noise alone, before the
    // inflation and the dispersions: what the bursts' information allows.
    if (joint.bias)
      joint_line["sigma_f_noise_percent"] =
          100.0 * joint.bias->sigma_f_noise_px / joint.fitted_camera.f;
    joint_line["iterations"] = joint.iterations;
    const Answer answer = ChooseAnswer(joint, fusion);
    answer_line["answered_by"] = CalibrationAnswerName(answer.choice.answer);
    answer_line["reason"] = answer.choice.reason;
    answer_line["f"] = answer.camera.f;
    Score(answer.camera, truth, &answer_line);
    answer_line["sigma_f_percent"] = answer.sigma_f_percent;
  } catch (const std::exception& e) {
    joint_line["failed"] = e.what();
    answer_line["failed"] = e.what();
  }
  joint_line["joint_ms"] = Milliseconds(start);
  joint_line["alone_ms"] = alone_ms;
  std::printf("%s\n", joint_line.dump().c_str());
  std::printf("%s\n", answer_line.dump().c_str());
  if (!pinned.empty()) PrintJointAtTruth(pinned, options, truth);
  return 0;
}

}  // namespace
}  // namespace dfsm

int main(int argc, char** argv) {
  using namespace dfsm;
  std::string dataset, images, calibration_file = TumFreiburg1CalibrationFile();
  int frames = 10, step = 12, start = 1, downscale = 1;
  int windows = std::numeric_limits<int>::max();
  double consistency_probability = 0.0;  // the option's default
  bool pinned_depth = false;
  std::vector<std::string> burst_dirs;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string option = argv[i];
      if (option.rfind("--", 0) != 0) {
        burst_dirs.push_back(option);
        continue;
      }
      if (i + 1 >= argc) throw std::invalid_argument(option + " needs a value");
      const char* value = argv[++i];
      if (option == "--dataset")
        dataset = value;
      else if (option == "--sequence")
        images = value;
      else if (option == "--frames")
        frames = WholeNumber("--frames", value, 3);
      else if (option == "--step")
        step = WholeNumber("--step", value, 1);
      else if (option == "--start")
        start = WholeNumber("--start", value, 0);
      else if (option == "--windows")
        windows = WholeNumber("--windows", value, 1);
      else if (option == "--downscale")
        downscale = WholeNumber("--downscale", value, 1);
      else if (option == "--calibration")
        calibration_file = value;
      else if (option == "--consistency")
        consistency_probability = PositiveNumber("--consistency", value);
      else if (option == "--pinned-depth")
        pinned_depth = OnOff("--pinned-depth", value);
      else
        throw std::invalid_argument("unknown option " + option +
                                    " (see the comment at the top of bench/joint_calibration.cc)");
    }
    if (dataset.empty() + images.empty() + burst_dirs.empty() != 2)
      throw std::invalid_argument("give one of --dataset DIR, --sequence DIR, burst directories");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "joint_calibration: %s\n", e.what());
    return 2;
  }
  std::vector<Input> inputs;
  std::optional<TumSequence> sequence;
  if (!dataset.empty()) {
    sequence.emplace(dataset, downscale);
    if (sequence->empty()) {
      std::fprintf(stderr, "joint_calibration: no TUM sequence at %s\n", dataset.c_str());
      return 77;
    }
    const CameraModel truth = sequence->ReadCalibration(calibration_file).camera;
    for (int first = start;
         first + frames <= sequence->frames() && static_cast<int>(inputs.size()) < windows;
         first += step)
      inputs.push_back({"window " + std::to_string(first),
                        [&sequence, first, frames] { return sequence->Window(first, frames); },
                        truth,
                        pinned_depth ? std::function<cv::Mat()>([&sequence, first, frames] {
                          return sequence->ReferenceDepth(first, frames);
                        })
                                     : nullptr});
  } else if (!images.empty()) {
    const int count = static_cast<int>(ListImageSequence(images).size());
    for (int first = start; first + frames <= count && static_cast<int>(inputs.size()) < windows;
         first += step)
      inputs.push_back(
          {"frames " + std::to_string(first) + "-" + std::to_string(first + frames - 1),
           [images, first, frames] {
             ImageSequenceOptions window;
             window.start = first;
             window.frames = frames;
             return ReadImageSequence(images, window);
           },
           std::nullopt, nullptr});
  } else {
    for (const std::string& dir : burst_dirs)
      inputs.push_back({dir, [dir] { return ReadBurst(dir); }, ReadGroundTruth(dir).camera,
                        pinned_depth
                            ? std::function<cv::Mat()>([dir] { return ReadGroundTruth(dir).depth; })
                            : nullptr});
  }
  return Run(inputs, consistency_probability);
}
