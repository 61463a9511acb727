#include "core/sparse/joint_adjustment.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <stdexcept>
#include <string>

#include "core/sparse/adjustment_problem.h"
#include "core/sparse/calibration_fusion.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {

const char* JointOutcomeName(JointOutcome outcome) {
  return outcome == JointOutcome::kJoined ? "joined" : "disagrees";
}

int JointCalibration::Joined() const {
  return static_cast<int>(std::count_if(bursts.begin(), bursts.end(), [](const auto& burst) {
    return burst.outcome == JointOutcome::kJoined;
  }));
}

JointBurst JointBurstOf(const std::string& name, const SparseReconstruction& sparse) {
  const std::optional<CameraModel> own = sparse.OwnCamera();
  if (!own)
    throw std::invalid_argument(name + ": no calibration of its own to join (" +
                                CalibrationSourceName(sparse.calibration_used) + ")");
  JointBurst burst;
  burst.name = name;
  burst.tracks = sparse.tracks;
  burst.tracks.weights.clear();
  burst.use = sparse.inliers;
  // The poses and inverse depths start where the burst's solution left them;
  // its camera is its own, not a known prior's pull or a fallback's.
  burst.state = sparse.state;
  burst.state.camera = *own;
  // The noise is the tracks' under the camera the burst ended with (a
  // fallback's refit included); sigma_f only where it is the own camera's.
  burst.noise_px = (sparse.self_estimate ? sparse.self_estimate->uncertainty : sparse.uncertainty)
                       .residual_sigma_px;
  const CalibrationUncertainty* own_uncertainty = sparse.OwnUncertainty();
  if (own_uncertainty && own_uncertainty->available)
    burst.sigma_f_percent = own_uncertainty->sigma_f_percent(own->f);
  return burst;
}

JointAdjustmentOptions JointOptionsFor(const SparseOptions& sparse) {
  JointAdjustmentOptions options;
  options.bundle_adjustment = sparse.bundle_adjustment;
  options.bundle_adjustment.estimate_readout =
      sparse.rolling_shutter.mode == RollingShutterOptions::Mode::kEstimate;
  options.quality = sparse.quality;
  options.bootstrap = sparse.bootstrap;
  return options;
}

void JointAdjustmentOptions::Check() const {
  bundle_adjustment.Check();
  quality.Check();
  if (bundle_adjustment.fix_intrinsics)
    throw std::invalid_argument(
        "bundle_adjustment.fix_intrinsics: a joint calibration estimates "
        "the camera");
  if (bundle_adjustment.angular_velocity_sigma_px > 0.0)
    throw std::invalid_argument(
        "bundle_adjustment.angular_velocity_sigma_px: the joint problem follows the line between "
        "frame poses (docs/experiments/045-the-joint-camera-at-true-depths.md)");
  if (!(consistency_probability > 0.0 && consistency_probability < 1.0))
    throw std::invalid_argument("consistency_probability must be in (0, 1)");
  if (max_starts < 1) throw std::invalid_argument("max_starts must be >= 1");
  if (min_bursts_to_leave_out < 4)
    throw std::invalid_argument("min_bursts_to_leave_out must be >= 4");
  if (profile_iterations < 1) throw std::invalid_argument("profile_iterations must be >= 1");
  bootstrap.Check();
}

namespace {

// A burst's cost under intrinsics held fixed: its poses and inverse depths
// (and the readout, where estimated) re-minimised, without the priors
// (constant under held intrinsics, they would only shift the cost). The
// readout trades against a tilt of the scene (docs/experiments/114), so a
// burst's own readout may differ from the shared one without another
// camera: it is not tested.
BundleAdjustmentOptions ProfileOptions(const JointAdjustmentOptions& options) {
  BundleAdjustmentOptions profile = options.bundle_adjustment;
  profile.fix_intrinsics = true;
  profile.max_iterations = options.profile_iterations;
  profile.log_f_prior_sigma = 0.0;
  profile.lens_k_prior_sigma = 0.0;
  profile.known_f_sigma_percent = 0.0;
  return profile;
}

struct Profile {
  SparseState state;
  double cost = std::numeric_limits<double>::infinity();
};

Profile ProfileUnder(const JointBurst& burst, const CameraModel& camera, double readout,
                     const BundleAdjustmentOptions& profile_options) {
  Profile profile{burst.state};
  profile.state.camera.f = camera.f;
  profile.state.camera.k1 = camera.k1;
  profile.state.camera.k2 = camera.k2;
  profile.state.readout = readout;
  profile.cost =
      RunBundleAdjustment(burst.tracks, burst.use, &profile.state, profile_options).final_cost;
  return profile;
}

// The bursts taking part in one round, and their states as the round leaves
// them.
struct Round {
  std::vector<int> active;  // indices into the bursts
  std::vector<SparseState> states;
  CameraModel camera;
  double readout = 0.0;
  double start_f = 0.0;  // the chosen start's
};

// The start: of the active bursts' own cameras (the most certain first, at
// most max_starts), the one under which the active bursts' profile costs sum
// lowest; each burst's profile state under it.
void ChooseStart(const std::vector<JointBurst>& bursts, const JointAdjustmentOptions& options,
                 Round* round) {
  std::vector<int> candidates = round->active;
  std::stable_sort(candidates.begin(), candidates.end(), [&](int a, int b) {
    const auto key = [&](int k) {
      return bursts[k].sigma_f_percent > 0.0 ? bursts[k].sigma_f_percent
                                             : std::numeric_limits<double>::infinity();
    };
    return key(a) < key(b);
  });
  if (static_cast<int>(candidates.size()) > options.max_starts)
    candidates.resize(options.max_starts);
  // One readout for every start: the bursts' median (they share the sensor).
  std::vector<double> readouts;
  for (const int k : round->active) readouts.push_back(bursts[k].state.readout);
  std::nth_element(readouts.begin(), readouts.begin() + readouts.size() / 2, readouts.end());
  round->readout = readouts[readouts.size() / 2];
  const BundleAdjustmentOptions profile_options = ProfileOptions(options);
  double best = std::numeric_limits<double>::infinity();
  for (const int c : candidates) {
    const CameraModel& camera = bursts[c].state.camera;
    std::vector<SparseState> states;
    double total = 0.0;
    for (const int k : round->active) {
      Profile profile = ProfileUnder(bursts[k], camera, round->readout, profile_options);
      total += profile.cost;
      states.push_back(std::move(profile.state));
    }
    if (total < best) {
      best = total;
      round->camera = camera;
      round->start_f = camera.f;
      round->states = std::move(states);
    }
  }
}

// The joint problem over one round's bursts: their residuals, each burst's
// gauge, the shared camera.
class JointProblem {
 public:
  JointProblem(const std::vector<JointBurst>& bursts, const JointAdjustmentOptions& options,
               Round* round)
      : bursts_(bursts),
        options_(options.bundle_adjustment),
        round_(round),
        huber_(options_.huber_px),
        problem_(ProblemOptions()),
        ordering_(new ceres::ParameterBlockOrdering) {
    intrinsics_[0] = round->camera.f;
    intrinsics_[1] = round->camera.k1;
    intrinsics_[2] = round->camera.k2;
    readout_ = round->readout;
    const bool rolling = readout_ != 0.0 || options_.estimate_readout;
    const size_t count = round->active.size();
    poses_.resize(count);
    blocks_.resize(count);
    for (size_t b = 0; b < count; ++b) {
      const JointBurst& burst = bursts_[round->active[b]];
      SparseState& state = round->states[b];
      for (const Pose& pose : state.poses) poses_[b].push_back(ToParameters(pose));
      reprojections_.push_back(std::make_unique<Reprojection>(burst.tracks, burst.state.camera,
                                                              rolling, burst.state.frame_times));
      const AdjustmentParameters parameters = Parameters(b);
      AddReprojectionResiduals(burst.tracks, burst.use, *reprojections_[b], parameters, &huber_,
                               &weighted_losses_, &problem_, ordering_, &blocks_[b]);
      anchors_.push_back(FixBurstGauge(burst.tracks, burst.use, parameters, &problem_, ordering_));
      if (options_.hold_inverse_depths) HoldInverseDepths(burst.use, parameters, &problem_);
    }
    AddIntrinsicsPriors(round->camera, options_, intrinsics_, &problem_, &prior_);
    ConstrainCamera(options_, rolling, intrinsics_, &readout_, &problem_, ordering_);
  }

  ceres::Solver::Summary Solve() {
    const ceres::LinearSolverType solver =
        ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) &&
                round_->active.size() > 1
            ? ceres::SPARSE_SCHUR
            : ceres::DENSE_SCHUR;
    // The shared camera is weakly observed, and the joint cost is large: one
    // sigma of f moves it by about one part in its residual count, and the
    // steps along f are small. One burst's relative tolerance would stop
    // the joint problem short of its minimum.
    BundleAdjustmentOptions solve = options_;
    solve.function_tolerance =
        std::min(options_.function_tolerance, 1e-4 / problem_.NumResiduals());
    const ceres::Solver::Summary summary = SolveAdjustment(solve, ordering_, &problem_, solver);
    round_->camera.f = intrinsics_[0];
    round_->camera.k1 = intrinsics_[1];
    round_->camera.k2 = intrinsics_[2];
    round_->readout = readout_;
    for (size_t b = 0; b < round_->active.size(); ++b) {
      SparseState& state = round_->states[b];
      state.camera.f = intrinsics_[0];
      state.camera.k1 = intrinsics_[1];
      state.camera.k2 = intrinsics_[2];
      state.readout = readout_;
      const int reference = bursts_[round_->active[b]].tracks.reference;
      for (size_t i = 0; i < state.poses.size(); ++i)
        state.poses[i] = static_cast<int>(i) == reference ? Pose{} : FromParameters(poses_[b][i]);
    }
    return summary;
  }

  // The marginal covariance of the shared intrinsics (and readout) at the
  // solution, from the joint problem's jacobians.
  CalibrationUncertainty Uncertainty() {
    std::vector<double*> poses, depths;
    std::vector<ceres::ResidualBlockId> reprojection;
    for (size_t b = 0; b < round_->active.size(); ++b) {
      const FeatureTracks& tracks = bursts_[round_->active[b]].tracks;
      for (int i = 0; i < tracks.num_frames(); ++i)
        if (i != tracks.reference) poses.push_back(poses_[b][i].data());
    }
    for (size_t b = 0; b < round_->active.size(); ++b) {
      const std::vector<bool>& use = bursts_[round_->active[b]].use;
      std::vector<double>& inverse_depths = round_->states[b].inverse_depths;
      for (size_t j = 0; j < inverse_depths.size(); ++j)
        if (use[j] && static_cast<int>(j) != anchors_[b]) depths.push_back(&inverse_depths[j]);
      reprojection.insert(reprojection.end(), blocks_[b].reprojection.begin(),
                          blocks_[b].reprojection.end());
    }
    AdjustmentJacobians jacobians = EvaluateJacobians(&problem_, intrinsics_, poses, &readout_, {},
                                                      depths, reprojection, prior_);
    int first_track = 0;
    for (size_t b = 0; b < round_->active.size(); ++b) {
      const FeatureTracks& tracks = bursts_[round_->active[b]].tracks;
      AddReferenceJacobians(tracks, *reprojections_[b], Parameters(b), blocks_[b], first_track,
                            &jacobians);
      const std::vector<double>& inverse_depths = round_->states[b].inverse_depths;
      jacobians.inverse_depths.insert(jacobians.inverse_depths.end(), inverse_depths.begin(),
                                      inverse_depths.end());
      first_track += tracks.num_tracks();
    }
    jacobians.noise_inflation = UncertaintyInflation(options_, round_->camera);
    CalibrationUncertainty uncertainty = MarginalIntrinsicsCovariance(jacobians);
    uncertainty.wide_angle_factor = WideAngleFactor(options_, round_->camera);
    PropagateToDistortion(round_->camera, &uncertainty);
    return uncertainty;
  }

 private:
  static ceres::Problem::Options ProblemOptions() {
    ceres::Problem::Options options;
    options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    return options;
  }
  AdjustmentParameters Parameters(size_t b) {
    return {intrinsics_, &poses_[b], &round_->states[b].inverse_depths, &readout_};
  }

  const std::vector<JointBurst>& bursts_;
  const BundleAdjustmentOptions options_;
  Round* round_;
  double intrinsics_[3];
  double readout_ = 0.0;
  std::vector<std::vector<std::array<double, 6>>> poses_;  // per burst, per frame
  std::vector<std::unique_ptr<Reprojection>> reprojections_;
  std::vector<AdjustmentResidualBlocks> blocks_;
  std::vector<ceres::ResidualBlockId> prior_;
  std::vector<int> anchors_;
  ceres::HuberLoss huber_;
  // Declared before the problem, which uses them to its end.
  std::vector<std::unique_ptr<ceres::ScaledLoss>> weighted_losses_;
  ceres::Problem problem_;
  ceres::ParameterBlockOrdering* ordering_;  // the solver takes it
};

double RmsOverUsed(const FeatureTracks& tracks, const std::vector<bool>& use,
                   const SparseState& state, double* sum_sq, int* count) {
  const std::vector<double> errors = TrackReprojectionErrors(tracks, state);
  double burst_sum = 0.0;
  int burst_count = 0;
  for (size_t j = 0; j < errors.size(); ++j)
    if (use[j]) burst_sum += errors[j] * errors[j], ++burst_count;
  *sum_sq += burst_sum;
  *count += burst_count;
  return burst_count > 0 ? std::sqrt(burst_sum / burst_count) : 0.0;
}

}  // namespace

namespace {

// The round's bias from the tracks' noise where it matters (as
// MeasureBiasIfItMatters decides for one burst, on the joint sigma_f before
// its inflation): every active burst's tracks replaced by ones its solution
// explains plus noise as large as its residuals, all adjusted jointly again
// from the solution; the replicas' mean camera less the solution's. The
// replicas run on OpenCV's pool, each single-threaded.
std::optional<IntrinsicsBias> JointBias(const std::vector<JointBurst>& bursts,
                                        const JointAdjustmentOptions& options, const Round& round,
                                        const CalibrationUncertainty& uncertainty) {
  const BootstrapBiasOptions& bootstrap = options.bootstrap;
  if (bootstrap.replicas == 0 || !uncertainty.available) return std::nullopt;
  const double sigma_f_noise = uncertainty.sigma_f_px() / uncertainty.inflation;
  if (!BiasMatters(sigma_f_noise, round.camera.f, bootstrap)) return std::nullopt;
  std::vector<FeatureTracks> explained;
  std::vector<double> noise;
  for (size_t b = 0; b < round.active.size(); ++b) {
    const JointBurst& burst = bursts[round.active[b]];
    explained.push_back(ExplainedTracks(burst.tracks, burst.use, round.states[b]));
    noise.push_back(
        ResidualNoisePx(burst.tracks, burst.use, round.states[b], options.bundle_adjustment));
  }
  JointAdjustmentOptions replica_options = options;
  replica_options.bundle_adjustment.num_threads = 1;  // the replicas share the pool instead
  std::vector<ReplicaEstimate> estimates(bootstrap.replicas);
  cv::parallel_for_(cv::Range(0, bootstrap.replicas), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      std::vector<JointBurst> replica(bursts.size());
      for (size_t b = 0; b < round.active.size(); ++b) {
        const JointBurst& burst = bursts[round.active[b]];
        JointBurst& copy = replica[round.active[b]];
        copy.tracks =
            ReplicaTracks(explained[b], burst.use, noise[b], bootstrap.seed + 104729 * b, r);
        copy.use = burst.use;
        copy.state = burst.state;
      }
      Round solution = round;
      JointProblem problem(replica, replica_options, &solution);
      const ceres::Solver::Summary summary = problem.Solve();
      estimates[r] = {solution.camera, solution.readout,
                      std::isfinite(summary.final_cost) && solution.camera.f > 0.0};
    }
  });
  IntrinsicsBias bias = MeanShift(estimates, round.camera, round.readout, bootstrap);
  bias.sigma_f_noise_px = sigma_f_noise;
  return bias;
}

// A burst's own minimum of the cost its profiles measure: its adjustment
// with the intrinsics (and the readout, where estimated) free as well, from
// its own solution, without priors. Where its stage refined its camera with
// each frame's angular velocity, that camera is not the minimum on the line
// between frame poses, which the joint problem and the profiles follow:
// measured from it, a rise can be negative. It runs to one adjustment's
// iteration budget, not profile_iterations: with its intrinsics free it has
// further to go than a profile.
double OwnMinimumCost(const JointBurst& burst, const JointAdjustmentOptions& options) {
  BundleAdjustmentOptions own = ProfileOptions(options);
  own.fix_intrinsics = false;
  own.max_iterations = options.bundle_adjustment.max_iterations;
  SparseState state = burst.state;
  return RunBundleAdjustment(burst.tracks, burst.use, &state, own).final_cost;
}

// Twice the rise of burst k's cost from its own minimum to `camera`, in
// units of its inflated noise variance (raw: before any dispersion).
double Disagreement(const std::vector<JointBurst>& bursts, int k,
                    const JointAdjustmentOptions& options, const CameraModel& camera,
                    double readout, double joint_noise_px, std::vector<double>* own_costs) {
  const BundleAdjustmentOptions profile_options = ProfileOptions(options);
  const JointBurst& burst = bursts[k];
  if (std::isinf((*own_costs)[k])) (*own_costs)[k] = OwnMinimumCost(burst, options);
  const double joint_cost = ProfileUnder(burst, camera, readout, profile_options).cost;
  const double noise = (burst.noise_px > 0.0 ? burst.noise_px : joint_noise_px) *
                       UncertaintyInflation(options.bundle_adjustment, camera);
  return 2.0 * (joint_cost - (*own_costs)[k]) / (noise * noise);
}

// One round solved: its bursts adjusted jointly from the best start, the
// covariance of the shared camera, and each burst's raw disagreement with it.
struct SolvedRound {
  Round round;
  CalibrationUncertainty uncertainty;
  ceres::Solver::Summary summary;
  std::vector<double> disagreements;  // raw, per active burst
};

SolvedRound SolveRound(const std::vector<JointBurst>& bursts, const JointAdjustmentOptions& options,
                       std::vector<int> active, std::vector<double>* own_costs) {
  SolvedRound solved;
  solved.round.active = std::move(active);
  ChooseStart(bursts, options, &solved.round);
  JointProblem problem(bursts, options, &solved.round);
  solved.summary = problem.Solve();
  // As for one burst: no covariance where the inverse depths are held.
  if (options.bundle_adjustment.hold_inverse_depths)
    solved.uncertainty.unavailable_reason = "the inverse depths are held";
  else
    solved.uncertainty = problem.Uncertainty();
  for (const int k : solved.round.active)
    solved.disagreements.push_back(Disagreement(bursts, k, options, solved.round.camera,
                                                solved.round.readout,
                                                solved.uncertainty.residual_sigma_px, own_costs));
  return solved;
}

// How much more the bursts of this round disagree than their noise says, all
// of them alike: the median disagreement over chi-square(3)'s median (at
// least 1). Real bursts share model errors that the generator's
// do not (a lens with more terms than the model, a rolling shutter that is
// not linear in the row), and every burst's own optimum then moves by more
// than its noise; scaled by the median, the test leaves out a burst that
// disagrees with the others, not every burst of an imperfect model.
double Dispersion(const std::vector<double>& disagreements) {
  std::vector<double> sorted = disagreements;
  std::sort(sorted.begin(), sorted.end());
  const size_t n = sorted.size();
  const double median = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  return std::max(1.0, median / ChiSquareQuantile(0.5, 3));
}

// How much more the round's bursts' own focal lengths scatter about the
// shared one than their own sigma_f says (a Birge ratio): the sum of
// ((f_k - f) / sigma_k)^2 over the bursts that have a sigma, divided by one
// less than their count, at least 1; `dispersion` where fewer than two have
// one. The disagreement's dispersion weighs f, k1 and k2 together, and a
// lens the model does not follow scatters k1 and k2 while the focal lengths
// agree (docs/sparse.md, "One camera over several bursts").
double FocalDispersion(const std::vector<JointBurst>& bursts, const Round& round,
                       double dispersion) {
  double sum = 0.0;
  int count = 0;
  for (const int k : round.active) {
    const JointBurst& burst = bursts[k];
    if (!(burst.sigma_f_percent > 0.0)) continue;
    const double sigma_px = burst.sigma_f_percent / 100.0 * burst.state.camera.f;
    const double deviation = (burst.state.camera.f - round.camera.f) / sigma_px;
    sum += deviation * deviation;
    ++count;
  }
  return count > 1 ? std::max(1.0, sum / (count - 1)) : dispersion;
}

// The shared camera's covariance scaled by how much more than their noise the
// bursts scatter, each intrinsic by its own measure (a quasi-likelihood's
// variance scale): f by `focal_dispersion`, k1, k2 and the readout by
// `dispersion`. D C D, D the scales' square roots, keeps it a covariance.
void ScaleByDispersion(double focal_dispersion, double dispersion, const CameraModel& camera,
                       CalibrationUncertainty* uncertainty) {
  const Eigen::Vector3d root(std::sqrt(focal_dispersion), std::sqrt(dispersion),
                             std::sqrt(dispersion));
  uncertainty->covariance = root.asDiagonal() * uncertainty->covariance * root.asDiagonal();
  if (uncertainty->sigma_readout > 0.0) uncertainty->sigma_readout *= std::sqrt(dispersion);
  PropagateToDistortion(camera, uncertainty);
}

// The verdict on the shared camera: as one burst's, on the joined bursts'
// evidence, and not reliable where as many bursts disagree as agree.
CalibrationVerdict JudgeJointly(const std::vector<JointBurst>& bursts,
                                const JointAdjustmentOptions& options,
                                const JointCalibration& joint) {
  CalibrationEvidence evidence;
  std::vector<double> motions;
  for (size_t k = 0; k < bursts.size(); ++k) {
    if (joint.bursts[k].outcome != JointOutcome::kJoined) continue;
    evidence.tracks += joint.bursts[k].tracks;
    motions.push_back(bursts[k].tracks.MedianMaxDisplacement());
  }
  std::nth_element(motions.begin(), motions.begin() + motions.size() / 2, motions.end());
  evidence.median_track_motion_px = motions[motions.size() / 2];
  evidence.rms_reprojection_px = joint.rms_reprojection_px;
  CalibrationVerdict verdict =
      JudgeCalibration(joint.camera, joint.uncertainty, evidence, options.quality);
  const int joined = joint.Joined();
  const int left_out = static_cast<int>(bursts.size()) - joined;
  if (joint.undecided) {
    verdict.reasons.push_back(
        "the bursts disagree more than their noise allows, and " + std::to_string(joined) +
        " are too few to tell which one is odd: another camera, a changed zoom or focus, or a "
        "lens the model does not fit");
    if (verdict.quality == CalibrationQuality::kReliable)
      verdict.quality = CalibrationQuality::kUncertain;
  }
  if (left_out > 0) {
    verdict.reasons.push_back(std::to_string(left_out) + " of " + std::to_string(bursts.size()) +
                              " bursts disagree with the shared camera and were left out "
                              "(another camera, or a changed zoom or focus?)");
    if (left_out >= joined && verdict.quality == CalibrationQuality::kReliable)
      verdict.quality = CalibrationQuality::kUncertain;
  }
  return verdict;
}

// Adjusts every burst jointly, then leaves out, one at a time, the burst that
// disagrees most where it disagrees with the others alone, its disagreement
// divided by theirs (Dispersion): a burst that pulled the joint camera
// towards itself cannot hide behind the scatter it caused. Each burst's
// outcome, and a left-out one's disagreement, go to `joint`; returns the last
// round.
SolvedRound LeaveOutDisagreeing(const std::vector<JointBurst>& bursts,
                                const JointAdjustmentOptions& options, JointCalibration* joint) {
  std::vector<int> all(bursts.size());
  for (size_t k = 0; k < bursts.size(); ++k) all[k] = static_cast<int>(k);
  std::vector<double> own_costs(bursts.size(), std::numeric_limits<double>::infinity());
  const double max_disagreement = ChiSquareQuantile(options.consistency_probability, 3);
  SolvedRound current = SolveRound(bursts, options, all, &own_costs);
  while (static_cast<int>(current.round.active.size()) >= options.min_bursts_to_leave_out) {
    const std::vector<double>& raw = current.disagreements;
    const size_t worst = std::max_element(raw.begin(), raw.end()) - raw.begin();
    if (raw[worst] <= max_disagreement) break;
    std::vector<int> rest = current.round.active;
    const int suspect = rest[worst];
    rest.erase(rest.begin() + worst);
    SolvedRound without = SolveRound(bursts, options, rest, &own_costs);
    const double disagreement =
        Disagreement(bursts, suspect, options, without.round.camera, without.round.readout,
                     without.uncertainty.residual_sigma_px, &own_costs) /
        Dispersion(without.disagreements);
    joint->bursts[suspect].disagreement = disagreement;
    if (disagreement <= max_disagreement) break;
    joint->bursts[suspect].outcome = JointOutcome::kDisagrees;
    current = std::move(without);
  }
  const double largest_raw =
      *std::max_element(current.disagreements.begin(), current.disagreements.end());
  joint->undecided =
      static_cast<int>(current.round.active.size()) < options.min_bursts_to_leave_out &&
      largest_raw > max_disagreement;
  return current;
}

// The joint calibration of the round `solved`: its dispersions, the
// covariance scaled by them, the noise bias taken off, each joined burst's
// poses and fit, and the verdict. `joint` holds the bursts' outcomes.
void Conclude(const std::vector<JointBurst>& bursts, const JointAdjustmentOptions& options,
              const SolvedRound& solved, JointCalibration* joint) {
  const Round& round = solved.round;
  joint->start_f = round.start_f;
  joint->iterations = solved.summary.num_successful_steps + solved.summary.num_unsuccessful_steps;
  joint->converged = solved.summary.termination_type == ceres::CONVERGENCE;
  joint->uncertainty = solved.uncertainty;
  joint->dispersion = Dispersion(solved.disagreements);
  for (size_t b = 0; b < round.active.size(); ++b)
    joint->bursts[round.active[b]].disagreement = solved.disagreements[b] / joint->dispersion;
  joint->fitted_camera = round.camera;
  joint->bias = JointBias(bursts, options, round, joint->uncertainty);
  joint->focal_dispersion = FocalDispersion(bursts, round, joint->dispersion);
  if (joint->uncertainty.available)
    ScaleByDispersion(joint->focal_dispersion, joint->dispersion, round.camera,
                      &joint->uncertainty);
  joint->camera = Debiased(round.camera, joint->bias);
  joint->readout = round.readout;
  double sum_sq = 0.0;
  int count = 0;
  for (size_t b = 0; b < round.active.size(); ++b) {
    const JointBurst& burst = bursts[round.active[b]];
    JointBurstResult& result = joint->bursts[round.active[b]];
    result.poses = round.states[b].poses;
    result.tracks = CountUsed(burst.use);
    result.rms_reprojection_px =
        RmsOverUsed(burst.tracks, burst.use, round.states[b], &sum_sq, &count);
  }
  joint->rms_reprojection_px = count > 0 ? std::sqrt(sum_sq / count) : 0.0;
  joint->verdict = JudgeJointly(bursts, options, *joint);
}

}  // namespace

JointCalibration AdjustJointly(const std::vector<JointBurst>& bursts,
                               const JointAdjustmentOptions& options) {
  options.Check();
  for (const JointBurst& burst : bursts)
    if (burst.state.camera.width != bursts.front().state.camera.width ||
        burst.state.camera.height != bursts.front().state.camera.height)
      throw ReconstructionError("joint calibration: bursts of different image sizes (" +
                                bursts.front().name + " and " + burst.name +
                                "): one camera's bursts share one size");
  if (bursts.empty()) throw ReconstructionError("joint calibration: no burst to adjust");
  JointCalibration joint;
  joint.bursts.resize(bursts.size());
  const SolvedRound solved = LeaveOutDisagreeing(bursts, options, &joint);
  Conclude(bursts, options, solved, &joint);
  return joint;
}

nlohmann::json ToJson(const JointCalibration& joint, const std::vector<JointBurst>& bursts) {
  nlohmann::json listed = nlohmann::json::array();
  for (size_t k = 0; k < bursts.size(); ++k) {
    const JointBurstResult& result = joint.bursts[k];
    nlohmann::json entry = {{"name", bursts[k].name},
                            {"outcome", JointOutcomeName(result.outcome)},
                            {"disagreement", result.disagreement}};
    if (result.outcome == JointOutcome::kJoined) {
      entry["tracks"] = result.tracks;
      entry["rms_reprojection_px"] = result.rms_reprojection_px;
      entry["poses"] = nlohmann::json::array();
      for (const Pose& pose : result.poses) entry["poses"].push_back(ToJson(pose));
    }
    listed.push_back(std::move(entry));
  }
  return {{"camera", ToJson(joint.camera)},
          {"readout", joint.readout},
          {"uncertainty", ToJson(joint.uncertainty, joint.camera.f)},
          {"verdict", ToJson(joint.verdict)},
          {"dispersion", joint.dispersion},
          {"focal_dispersion", joint.focal_dispersion},
          {"undecided", joint.undecided},
          {"bursts_joined", joint.Joined()},
          {"start_f", joint.start_f},
          {"iterations", joint.iterations},
          {"converged", joint.converged},
          {"rms_reprojection_px", joint.rms_reprojection_px},
          {"bursts", std::move(listed)}};
}

std::optional<KnownCalibration> JointCalibrationPrior(const nlohmann::json& joint,
                                                      std::string* why) {
  if (joint.contains("answer") && joint.at("answer").value("method", "") == "fused") {
    const nlohmann::json& answer = joint.at("answer");
    KnownCalibration known = FusedCalibrationPrior(
        CameraModelFromJson(answer.at("camera")), answer.at("sigma_f_percent").get<double>(),
        answer.at("distortion_sigma_px").get<double>(),
        "fused (" + std::to_string(answer.at("bursts").get<int>()) +
            " bursts; the joint calibration's answer: " + answer.value("reason", "") + ")");
    known.check_fit = true;
    return known;
  }
  const nlohmann::json& uncertainty = joint.at("uncertainty");
  const std::string quality = joint.at("verdict").value("quality", "");
  const std::string bursts = std::to_string(joint.at("bursts_joined").get<int>()) + " bursts";
  if (quality == "degenerate") {
    *why = "the joint calibration of " + bursts + " is degenerate";
    return std::nullopt;
  }
  if (!uncertainty.value("available", false)) {
    *why = "the joint calibration of " + bursts + " has no uncertainty";
    return std::nullopt;
  }
  KnownCalibration known = FusedCalibrationPrior(
      CameraModelFromJson(joint.at("camera")), uncertainty.at("sigma_f_percent").get<double>(),
      uncertainty.at("distortion_sigma_px").get<double>(),
      "joint (" + bursts + ", " + quality + ")");
  known.check_fit = true;
  return known;
}

}  // namespace dfsm
