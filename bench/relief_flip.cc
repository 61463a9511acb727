// Can the tracks tell a relief from its mirror? Small motion leaves a
// near-ambiguity: inverse depths mirrored about their median (near made far)
// with the translation reversed move the tracks almost as the true ones do,
// the rotation taking up the rest. A JSON report, not a timing benchmark
// (docs/experiments/007-relief-flip.md): per burst, the order of the sparse
// stage's inverse depths (the stage as a job runs it, ReconstructSparseStage) against the truth
// (Spearman's rho: +1 right, -1 inverted) and how much relief they hold beyond a smooth surface
// (relief_against_truth), and the adjustment's cost from the mirrored start
// against the cost at the solution, both with the intrinsics held. On a TUM sequence with a motion
// capture (groundtruth.txt), also the adjustment from its poses and the Kinect's inverse depths:
// whether the solution's minimum or its start keeps it from the truth
// (docs/experiments/008-motion-capture-poses.md).
//
//   relief_flip [--bursts N] [--seed S] [--camera ideal|webcam|phone]
//   relief_flip --tum DATASET [--start I] [--step J]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <nlohmann/json.hpp>
#include <numeric>
#include <string>
#include <vector>

#include "bench/report_options.h"
#include "bench/tum_sequence.h"
#include "core/pipeline/pipeline.h"
#include "core/sparse/sparse_reconstruction.h"
#include "core/synth/burst_synthesizer.h"
#include "tests/support/calibration_sweep.h"

namespace dfsm {
namespace {

std::vector<double> Ranks(const std::vector<double>& values) {
  std::vector<int> order(values.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return values[a] < values[b]; });
  std::vector<double> ranks(values.size());
  for (size_t r = 0; r < order.size(); ++r) ranks[order[r]] = static_cast<double>(r);
  return ranks;
}

double Spearman(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() < 3) return 0.0;
  const std::vector<double> ra = Ranks(a), rb = Ranks(b);
  const double mean = (a.size() - 1) / 2.0;
  double ab = 0, aa = 0, bb = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    ab += (ra[i] - mean) * (rb[i] - mean);
    aa += (ra[i] - mean) * (ra[i] - mean);
    bb += (rb[i] - mean) * (rb[i] - mean);
  }
  return ab / std::sqrt(aa * bb);
}

// The inlier tracks whose reference pixel has a true depth, with the true
// inverse depth there.
struct TrackTruth {
  int track;
  double inverse_depth;
};
std::vector<TrackTruth> TruthAtInliers(const SparseReconstruction& sparse, const cv::Mat& depth) {
  std::vector<TrackTruth> found;
  const Eigen::Matrix2Xd& pixels = sparse.tracks.pixels[sparse.tracks.reference];
  for (int i = 0; i < sparse.tracks.num_tracks(); ++i) {
    if (!sparse.inliers[i]) continue;
    const int x = static_cast<int>(std::lround(pixels(0, i)));
    const int y = static_cast<int>(std::lround(pixels(1, i)));
    if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows) continue;
    const float z = depth.at<float>(y, x);
    if (z > 0.0f) found.push_back({i, 1.0 / z});
  }
  return found;
}

// The order of `state`'s inverse depths against the true inverse depth at
// each used track's reference pixel (0 where the truth has none: skipped).
double OrderAgainstTruth(const SparseReconstruction& sparse, const SparseState& state,
                         const cv::Mat& depth) {
  std::vector<double> estimated, truth;
  for (const TrackTruth& found : TruthAtInliers(sparse, depth)) {
    estimated.push_back(state.inverse_depths[found.track]);
    truth.push_back(found.inverse_depth);
  }
  return Spearman(estimated, truth);
}

// The mean relative depth error, over the rows of `model`, of the truth's
// inverse depths fitted by least squares in relative inverse depth; a
// prediction behind the camera counts as 100 %.
double FitError(const Eigen::MatrixXd& model, const Eigen::VectorXd& truth) {
  Eigen::MatrixXd relative = model;
  for (int i = 0; i < model.rows(); ++i) relative.row(i) /= truth(i);
  const Eigen::VectorXd fit =
      relative.colPivHouseholderQr().solve(Eigen::VectorXd::Ones(truth.size()));
  const Eigen::VectorXd predicted = model * fit;
  double sum = 0.0;
  for (int i = 0; i < truth.size(); ++i)
    sum += predicted(i) > 0.0 ? std::min(1.0, std::abs(truth(i) / predicted(i) - 1.0)) : 1.0;
  return sum / truth.size();
}

// How much relief the used tracks hold against the truth's inverse depth at
// their reference pixels: the fit error (FitError) of s w, of s w + b + c x +
// d y, and of a quadric in the pixel coordinates alone, the tracks' depths
// unused (a smooth surface through the truth's points).
nlohmann::json ReliefAgainstTruth(const SparseReconstruction& sparse, const SparseState& state,
                                  const cv::Mat& depth) {
  const Eigen::Matrix2Xd& pixels = sparse.tracks.pixels[sparse.tracks.reference];
  const std::vector<TrackTruth> truth = TruthAtInliers(sparse, depth);
  const int n = static_cast<int>(truth.size());
  if (n < 8) return nullptr;
  Eigen::MatrixXd scale(n, 1), tilted(n, 4), quadric(n, 6);
  Eigen::VectorXd true_w(n);
  for (int i = 0; i < n; ++i) {
    const int j = truth[i].track;
    const double w = state.inverse_depths[j];
    const double x = (pixels(0, j) - state.camera.cx) / state.camera.f;
    const double y = (pixels(1, j) - state.camera.cy) / state.camera.f;
    scale.row(i) << w;
    tilted.row(i) << w, 1.0, x, y;
    quadric.row(i) << 1.0, x, y, x * x, x * y, y * y;
    true_w(i) = truth[i].inverse_depth;
  }
  return {{"tracks", n},
          {"scale", FitError(scale, true_w)},
          {"scale_offset_tilt", FitError(tilted, true_w)},
          {"quadric_alone", FitError(quadric, true_w)}};
}

// `state` with its relief mirrored about the median inverse depth and its
// translations reversed (kept in front of the camera).
SparseState Mirrored(const SparseState& state) {
  SparseState mirrored = state;
  std::vector<double> sorted = state.inverse_depths;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  for (double& w : mirrored.inverse_depths) w = std::max(2.0 * median - w, 0.05 * median);
  for (Pose& pose : mirrored.poses) pose.T = -pose.T;
  return mirrored;
}

// `state` moved to the motion capture's poses and the Kinect's inverse depth
// at each track's reference pixel (the median where it has none), scaled to
// `state`'s median inverse depth; its camera and readout kept.
SparseState FromMotionCapture(const SparseReconstruction& sparse, const SparseState& state,
                              const std::vector<Pose>& truth, const cv::Mat& depth) {
  SparseState moved = state;
  const Eigen::Matrix2Xd& pixels = sparse.tracks.pixels[sparse.tracks.reference];
  std::vector<double> measured;
  for (int i = 0; i < sparse.tracks.num_tracks(); ++i) {
    const int x = static_cast<int>(std::lround(pixels(0, i)));
    const int y = static_cast<int>(std::lround(pixels(1, i)));
    const bool inside = x >= 0 && y >= 0 && x < depth.cols && y < depth.rows;
    const float z = inside ? depth.at<float>(y, x) : 0.0f;
    moved.inverse_depths[i] = z > 0.0f ? 1.0 / z : -1.0;
    if (z > 0.0f) measured.push_back(1.0 / z);
  }
  std::vector<double> sorted = state.inverse_depths;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  std::nth_element(measured.begin(), measured.begin() + measured.size() / 2, measured.end());
  const double true_median = measured[measured.size() / 2];
  const double scale = sorted[sorted.size() / 2] / true_median;
  for (double& w : moved.inverse_depths) w = scale * (w > 0.0 ? w : true_median);
  for (size_t i = 0; i < moved.poses.size(); ++i) {
    moved.poses[i].R = truth[i].R;
    moved.poses[i].T = truth[i].T / scale;
  }
  return moved;
}

nlohmann::json Compare(const std::string& name, const Burst& burst, const cv::Mat& depth,
                       const std::vector<Pose>& truth = {}) {
  nlohmann::json line = {{"burst", name}};
  SparseReconstruction sparse;
  try {
    PipelineOptions options;
    options.sparse.mirrored_relief = false;  // the ambiguity as the adjustment leaves it
    sparse = ReconstructSparseStage(burst, options);
  } catch (const ReconstructionError& e) {
    line["error"] = e.what();
    return line;
  }
  // The poses are those of the frames the tracks run through.
  const std::vector<Pose> kept_truth = PosesOfFrames(truth, sparse.feature_stats.kept_frames);
  BundleAdjustmentOptions held;
  held.fix_intrinsics = true;
  held.max_iterations = 100;
  SparseState at_solution = sparse.state;
  const BundleAdjustmentSummary solution =
      RunBundleAdjustment(sparse.tracks, sparse.inliers, &at_solution, held);
  SparseState mirrored = Mirrored(sparse.state);
  const double order_mirrored_start = OrderAgainstTruth(sparse, mirrored, depth);
  const BundleAdjustmentSummary from_mirror =
      RunBundleAdjustment(sparse.tracks, sparse.inliers, &mirrored, held);
  line["order"] = OrderAgainstTruth(sparse, at_solution, depth);
  line["relief_against_truth"] = ReliefAgainstTruth(sparse, at_solution, depth);
  line["order_mirrored_start"] = order_mirrored_start;
  line["order_from_mirror"] = OrderAgainstTruth(sparse, mirrored, depth);
  line["cost"] = solution.final_cost;
  line["cost_from_mirror"] = from_mirror.final_cost;
  line["cost_ratio"] = from_mirror.final_cost / std::max(solution.final_cost, 1e-12);
  if (!kept_truth.empty()) {
    SparseState from_truth = FromMotionCapture(sparse, at_solution, kept_truth, depth);
    line["translation_residual"] = TranslationResidual(at_solution.poses, kept_truth);
    line["order_truth_start"] = OrderAgainstTruth(sparse, from_truth, depth);
    const BundleAdjustmentSummary truth_run =
        RunBundleAdjustment(sparse.tracks, sparse.inliers, &from_truth, held);
    line["cost_from_truth"] = truth_run.final_cost;
    line["cost_ratio_truth"] = truth_run.final_cost / std::max(solution.final_cost, 1e-12);
    line["order_from_truth"] = OrderAgainstTruth(sparse, from_truth, depth);
    line["translation_residual_from_truth"] = TranslationResidual(from_truth.poses, kept_truth);
  }
  line["tracks"] = CountUsed(sparse.inliers);
  line["frames_left_out"] = sparse.feature_stats.left_out.size();
  line["f"] = sparse.state.camera.f;
  return line;
}

int RunGenerated(int bursts, unsigned seed, const std::string& camera) {
  for (const SynthOptions& settings :
       CalibrationSweepSettings(bursts, seed, SweepFieldOfView::kNormal,
                                CameraEffects::Preset(camera), SweepMotion::kTremor)) {
    const SynthBurst synth = SynthesizeBurst(settings);
    nlohmann::json line =
        Compare(std::to_string(settings.width) + "x" + std::to_string(settings.height) + " seed " +
                    std::to_string(settings.seed),
                ToBurst(synth), synth.truth.depth);
    line["rotation_deg"] = settings.rotation_deg;
    std::printf("%s\n", line.dump().c_str());
    std::fflush(stdout);
  }
  return 0;
}

int RunTum(const std::string& dataset, int start, int step) {
  const TumSequence sequence(dataset);
  if (sequence.empty()) {
    std::fprintf(stderr, "%s: no TUM sequence\n", dataset.c_str());
    return 1;
  }
  for (int first = start; first + 10 <= sequence.frames(); first += step) {
    std::printf("%s\n", Compare("window " + std::to_string(first), sequence.Window(first, 10),
                                sequence.ReferenceDepth(first, 10), sequence.TruePoses(first, 10))
                            .dump()
                            .c_str());
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace
}  // namespace dfsm

int main(int argc, char** argv) {
  int bursts = 16, start = 1, step = 12;
  unsigned seed = 3;
  std::string camera = "phone", tum;
  try {
    for (int i = 1; i < argc; ++i) {
      const bool value = i + 1 < argc;
      if (!std::strcmp(argv[i], "--bursts") && value)
        bursts = dfsm::WholeNumber("--bursts", argv[++i], 1);
      else if (!std::strcmp(argv[i], "--seed") && value)
        seed = static_cast<unsigned>(dfsm::SeedNumber("--seed", argv[++i]));
      else if (!std::strcmp(argv[i], "--camera") && value)
        camera = argv[++i];
      else if (!std::strcmp(argv[i], "--tum") && value)
        tum = argv[++i];
      else if (!std::strcmp(argv[i], "--start") && value)
        start = dfsm::WholeNumber("--start", argv[++i], 0);
      else if (!std::strcmp(argv[i], "--step") && value)
        step = dfsm::WholeNumber("--step", argv[++i], 1);
      else {
        std::fprintf(stderr,
                     "usage: relief_flip [--bursts N] [--seed S] [--camera ideal|webcam|phone]\n"
                     "       relief_flip --tum DATASET [--start I] [--step J]\n");
        return 2;
      }
    }
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "relief_flip: %s\n", e.what());
    return 2;
  }
  try {
    if (!tum.empty()) return dfsm::RunTum(tum, start, step);
    return dfsm::RunGenerated(bursts, seed, camera);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "relief_flip: %s\n", e.what());
    return 1;
  }
}
