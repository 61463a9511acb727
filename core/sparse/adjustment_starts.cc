#include "core/sparse/adjustment_starts.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <string>

#include "core/parallel/parallel_for.h"
#include "core/parallel/shared_work.h"
#include "core/sparse/fixed_text.h"
#include "core/sparse/robust_sigma.h"
#include "core/sparse/rolling_shutter_rectification.h"
#include "core/sparse/rotation_init.h"

namespace dfsm {
namespace {

// Rounds of rectifying and re-initializing (measured at 1080p, readout 0.6:
// rotation error 0.35 -> 0.052 -> 0.014 -> 0.006 deg).
constexpr int kRectificationRounds = 3;
// Readouts the adjustment also restarts from where it estimates the readout.
// A readout and a top-to-bottom tilt of the scene trade against each other
// when the camera moves up and down (docs/experiments/114-readout-sigma-tum-18-27.md):
// the adjustment has two minima there, and which it
// reaches depends on the start. Starts nearer than kSameReadoutStart to one
// already tried return to the same minimum and are skipped.
constexpr double kReadoutStarts[] = {0.5, 1.0};
constexpr double kSameReadoutStart = 0.15;
// Iterations of the first adjustment where it estimates the readout: it only
// measures the readout for the restarts, which converge from there in a few
// iterations: on phone bursts an uncapped one crawls along a narrow valley
// to its 100-iteration cap, where the restart from its readout converges
// lower in a few. Where it measures no readout it goes on to the full
// budget, since no restart follows
// (docs/experiments/117-first-adjustment-budget.md).
constexpr int kMeasuringIterations = 30;

// A later start (focal, or the naive probe) replaces the solution so far
// where its truncated cost is lower by more than this fraction. Two starts that reach the same
// minimum differ by far less, and the earlier one (the paper's guess first) stands.
constexpr double kLaterStartGain = 0.01;
// A later start is probed: its initialization and first adjustment, stopped
// after this many iterations, and only the winner goes on
// to the readout restarts and outlier rounds. A start near the camera reaches
// its minimum in a few iterations; one far from it (0.6 on a normal lens)
// crawled along the f valley to the 100-iteration cap in every run and round
// (370 ms more at 1080p), to lose anyway.
constexpr int kProbeIterations = 20;
// A probe adjusts at most this many of its tracks (and at least
// SparseOptions::min_tracks), spread evenly over them in grid order (so over
// the image as the grid spreads them): which minimum a start falls into is a
// matter of the geometry, which a few hundred tracks fix as well as all of
// them, and an iteration's cost grows with the tracks. The starts are
// compared over every track, each at its best depth under a start's camera
// and poses (TruncatedTrackCost), so the tracks a probe left out count as
// the others do; a probe that wins takes them in before it goes on.
constexpr int kProbeTracks = 160;

// Keeps `most` of the `use` tracks, evenly spaced among them (the n-th of
// `used` where floor(n * most / used) steps up); returns whether any was
// left out.
bool ThinTracks(int most, std::vector<bool>* use) {
  const long used = std::count(use->begin(), use->end(), true);
  if (most <= 0 || used <= most) return false;
  long n = 0;
  for (size_t j = 0; j < use->size(); ++j)
    if ((*use)[j]) {
      (*use)[j] = (n * most) / used != ((n + 1) * most) / used;
      ++n;
    }
  return true;
}

// The outlier rule of the rounds after the adjustment: the tracks of `use`
// (and of `use` only, their inverse depths being the adjusted ones) within
// max(outlier_px, 4 robust sigmas) of the state's reprojection, in front.
std::vector<bool> KeptTracks(const FeatureTracks& tracks, const SparseState& state,
                             const std::vector<bool>& use, const SparseOptions& options) {
  const std::vector<double> errors = TrackReprojectionErrors(tracks, state);
  std::vector<double> used_errors;
  for (size_t j = 0; j < errors.size(); ++j)
    if (use[j]) used_errors.push_back(errors[j]);
  const double threshold = std::max(options.outlier_px, 4.0 * RobustSigma(used_errors));
  std::vector<bool> kept(errors.size());
  for (size_t j = 0; j < errors.size(); ++j)
    kept[j] = errors[j] <= threshold && state.inverse_depths[j] > 0.0;
  return kept;
}

// The adjustment's fit to every track, inliers or not, robustly: each track's
// squared RMS reprojection error, capped at threshold^2, summed. A solution
// that keeps fewer tracks pays for the ones it loses, and one that fits its
// inliers more closely gains; a median alone preferred, on a wide-lens burst,
// a camera 10 % off that fitted fewer tracks to a larger mean error. Each
// track at its best inverse depth under the solution's camera and poses: a
// track an outlier round dropped keeps the depth of the round before, which
// gave a start with more rounds behind it (the first) a handicap against a
// probe that adjusted every track.
double TruncatedTrackCost(const FeatureTracks& tracks, const SparseState& state, double threshold) {
  double cost = 0.0;
  for (const double error : TrackReprojectionErrorsAtBestDepth(tracks, state))
    cost += std::isfinite(error) ? std::min(error * error, threshold * threshold)
                                 : threshold * threshold;
  return cost;
}

// Each track's weight from its own RMS reprojection error e under `state`:
// (m / e)^2 where e exceeds the median m of the used tracks' errors, at least
// min_weight; 1 elsewhere. A track's ~2 (frames - 1) residuals measure its
// noise to a few tens of percent, enough to tell a crisp corner from one
// that tracks several times worse; those at or below the median are not
// raised, so no few tracks can take the adjustment over.
std::vector<double> TrackWeights(const FeatureTracks& tracks, const SparseState& state,
                                 const std::vector<bool>& use, double min_weight) {
  const std::vector<double> errors = TrackReprojectionErrors(tracks, state);
  std::vector<double> used;
  for (size_t j = 0; j < errors.size(); ++j)
    if (use[j] && std::isfinite(errors[j])) used.push_back(errors[j]);
  std::vector<double> weights(errors.size(), 1.0);
  if (used.empty()) return weights;
  std::nth_element(used.begin(), used.begin() + used.size() / 2, used.end());
  const double median = used[used.size() / 2];
  for (size_t j = 0; j < errors.size(); ++j)
    if (use[j] && std::isfinite(errors[j]) && errors[j] > median)
      weights[j] = std::max(min_weight, (median / errors[j]) * (median / errors[j]));
  return weights;
}

double MedianTrackError(const FeatureTracks& tracks, const SparseState& state) {
  std::vector<double> errors = TrackReprojectionErrors(tracks, state);
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

int TotalIterations(const std::vector<BundleAdjustmentRun>& runs) {
  int iterations = 0;
  for (const BundleAdjustmentRun& run : runs) iterations += run.iterations;
  return iterations;
}

// The record of a start that reached a solution compared by `cost`.
StartRecord Record(StartKind kind, const AdjustmentAttempt& attempt, double cost,
                   StartOutcome outcome) {
  StartRecord record;
  record.kind = kind;
  record.start_f = attempt.start_f;
  record.tracks = attempt.runs.empty() ? 0 : attempt.runs.front().tracks;
  record.iterations = TotalIterations(attempt.runs);
  record.cost = cost;
  record.outcome = outcome;
  return record;
}

// Laps `timer` where there is one: only the first start is timed.
void LapIfTimed(StageTimer* timer, const char* stage, double carried_ms = 0.0) {
  if (timer) timer->Lap(stage, carried_ms);
}

// The steps of one start, over the tracks of one burst.
class StartedAdjustment {
 public:
  StartedAdjustment(const FeatureTracks& tracks, const SparseOptions& options)
      : tracks_(tracks), options_(options), rank_one_(options.init == InitMode::kRankOne) {}
  StartedAdjustment(const StartedAdjustment&) = delete;

  // The initialization and the first adjustment from `start_camera` (laps
  // `timer` where there is one); returns the iterations that adjustment was
  // allowed, for Finish(). Throws ReconstructionError.
  // A probe passes `most_tracks` (> 0) to adjust at most that many.
  int Solve(const CameraModel& start_camera, const BundleAdjustmentOptions& adjust,
            StageTimer* timer, AdjustmentAttempt* attempt, int most_tracks = 0) const {
    SparseState& state = attempt->state;
    state.camera = start_camera;
    state.frame_times = options_.frame_times;
    state.readout = options_.rolling_shutter.mode == RollingShutterOptions::Mode::kKnown
                        ? options_.rolling_shutter.readout
                        : 0.0;
    attempt->use.assign(tracks_.num_tracks(), true);
    if (rank_one_) {
      const std::vector<Eigen::Matrix3d> rotations = EstimateRotations(tracks_, start_camera);
      LapIfTimed(timer, "rotation");
      attempt->rank_one = RankOneInit(tracks_, start_camera, rotations, options_.rank_one);
      LapIfTimed(timer, "rank1");
      if (!attempt->rank_one.ok)
        throw ReconstructionError("rank-1 initialization failed: fewer than 3 consistent tracks");
      state.poses = attempt->rank_one.poses;
      state.inverse_depths = attempt->rank_one.inverse_depths;
      attempt->use = attempt->rank_one.inliers;
    } else {
      // The reference code's start: no motion, random inverse depths.
      state.poses.assign(tracks_.num_frames(), Pose{});
      std::mt19937_64 random(options_.naive_seed);
      std::uniform_real_distribution<double> uniform(0.01, 1.0);
      state.inverse_depths.resize(tracks_.num_tracks());
      for (double& w : state.inverse_depths) w = uniform(random);
      LapIfTimed(timer, "rotation");
      LapIfTimed(timer, "rank1");
    }
    if (CountUsed(attempt->use) < options_.min_tracks)
      throw ReconstructionError("too few consistent tracks after outlier rejection: " +
                                std::to_string(CountUsed(attempt->use)) +
                                " (need >= " + std::to_string(options_.min_tracks) + ")");

    if (rank_one_ && std::abs(state.readout) >= kMinEffectiveReadout)
      RectifiedStart(state.camera, state.poses, state.readout, attempt);
    BundleAdjustmentOptions measuring = adjust;
    if (rank_one_ && adjust.estimate_readout)
      measuring.max_iterations = std::min(measuring.max_iterations, kMeasuringIterations);
    std::vector<bool> all = attempt->use;
    if (ThinTracks(most_tracks, &attempt->use)) attempt->thinned_from = std::move(all);
    attempt->Adjust(tracks_, measuring);
    return measuring.max_iterations;
  }

  // Whether Settle() restarts from several readouts: the adjustment so far
  // measured one.
  bool Restarts(const BundleAdjustmentOptions& adjust, const AdjustmentAttempt& attempt) const {
    return rank_one_ && options_.readout_restarts && adjust.estimate_readout &&
           std::abs(attempt.state.readout) >= kMinEffectiveReadout;
  }

  // After the first adjustment: Continue(), then Settle(). A thinned probe
  // first gives every track it left out its best depth under its geometry
  // (so the outlier rounds judge them as the others, not at the start's
  // depths), takes in those its geometry explains (within outlier_px, in
  // front) and adjusts them all once: with the whole budget, or only
  // kMeasuringIterations where readout restarts follow (as a first start
  // measures the readout for them). Taking in every track, the ones its
  // geometry does not explain included, sent a 1080p burst (2 deg) to 19
  // tracks in front.
  void Finish(const BundleAdjustmentOptions& adjust, int measured_iterations,
              AdjustmentAttempt* attempt) const {
    if (!attempt->thinned_from.empty()) {
      std::vector<double> best;
      const std::vector<double> errors =
          TrackReprojectionErrorsAtBestDepth(tracks_, attempt->state, &best);
      for (size_t j = 0; j < best.size(); ++j) {
        if (attempt->use[j] || !(best[j] > 0.0)) continue;
        attempt->state.inverse_depths[j] = best[j];
        if (attempt->thinned_from[j] && errors[j] <= options_.outlier_px) attempt->use[j] = true;
      }
      attempt->thinned_from.clear();
      BundleAdjustmentOptions taken_in = adjust;
      if (Restarts(adjust, *attempt))
        taken_in.max_iterations = std::min(taken_in.max_iterations, kMeasuringIterations);
      attempt->Adjust(tracks_, taken_in);
    } else {
      Continue(adjust, measured_iterations, attempt);
    }
    Settle(adjust, attempt);
  }

  // The rest of the first adjustment's budget where no readout restart
  // follows to go on from it (a global shutter, a known readout, the naive
  // start): a probe that won must not stay at its capped iterations.
  void Continue(const BundleAdjustmentOptions& adjust, int measured_iterations,
                AdjustmentAttempt* attempt) const {
    if (measured_iterations < adjust.max_iterations && !attempt->summary.converged &&
        !Restarts(adjust, *attempt))
      attempt->Adjust(tracks_, adjust);
  }

  // The readout restarts (where Restarts()), then the outlier rounds.
  void Settle(const BundleAdjustmentOptions& adjust, AdjustmentAttempt* attempt) const {
    if (Restarts(adjust, *attempt)) Restart(adjust, attempt);
    // Judge every track again under the adjusted camera: tracks the initial
    // camera made look wrong come back, tracks that do not fit go, and a short
    // re-run from the adjusted state settles the set. A track on a depth edge
    // (a T-junction, not a point of the scene) fits to a few tenths of a pixel
    // and still pulls f against k1/k2, so the bound is tight and the rounds
    // repeat until the set stops changing.
    const double initial_cost = attempt->summary.initial_cost;
    for (int round = 0; round < options_.outlier_rounds; ++round) {
      const std::vector<bool> kept = KeptTracks(tracks_, attempt->state, attempt->use, options_);
      if (kept == attempt->use || CountUsed(kept) < options_.min_tracks) break;
      attempt->use = kept;
      attempt->Adjust(tracks_, adjust);
      attempt->summary.initial_cost = initial_cost;
    }
  }

  // The poses and inverse depths refined with each track weighed by its own
  // noise (SparseOptions::reweight_rounds), the camera held: the weights from
  // the errors of the settled set, the adjustment rerun from where it stands;
  // a second round takes the weights from the weighted solution's errors.
  // Only on the start that won: the starts are compared as they were
  // settled, by their fit to every track with equal weights.
  void Reweight(const BundleAdjustmentOptions& adjust, AdjustmentAttempt* attempt) const {
    const double initial_cost = attempt->summary.initial_cost;
    // f, k1, k2 and the readout stay the equal-weight solution's: with the
    // intrinsics free, the weights took the calibration's evidence away where
    // the lens departs most from the model (the corners' tracks fit worst),
    // and its sigmas shrank as its errors grew (docs/experiments/125-track-weights.md).
    BundleAdjustmentOptions held = adjust;
    held.fix_intrinsics = true;
    held.estimate_readout = false;
    for (int round = 0; round < options_.reweight_rounds; ++round) {
      attempt->weights =
          TrackWeights(tracks_, attempt->state, attempt->use, options_.min_track_weight);
      attempt->Adjust(tracks_, held);
      attempt->summary.initial_cost = initial_cost;
    }
  }

 private:
  // A rolling shutter: the global-shutter rank-1 start is far off under a
  // phone's readout (rolling_shutter_rectification.h), so the adjustment
  // starts from a rank-1 initialization of the tracks rectified with the
  // readout: the known one at once; an estimated one after a first
  // adjustment has measured it. Sets `start`'s state, tracks and rank-1
  // result, or returns false and leaves it as it was.
  bool RectifiedStart(const CameraModel& camera, const std::vector<Pose>& poses, double readout,
                      AdjustmentAttempt* start) const {
    RankOneResult init = RectifiedRankOneInit(tracks_, camera, poses, readout, kRectificationRounds,
                                              options_.rank_one, options_.frame_times);
    if (!init.ok || CountUsed(init.inliers) < options_.min_tracks) return false;
    start->state.camera = camera;
    start->state.poses = init.poses;
    start->state.inverse_depths = init.inverse_depths;
    start->state.readout = readout;
    start->state.frame_times = options_.frame_times;
    start->use = init.inliers;
    start->rank_one = std::move(init);
    return true;
  }

  // Restarts from the readout the first adjustment measured and from
  // kReadoutStarts, each rectified with the first adjustment's camera and
  // poses; the best fit over every track wins, not each start's own inliers:
  // a wrong minimum fits its few inliers as well as the right one fits many.
  // Where the first adjustment measured no readout (a global shutter), none is
  // tried: those restarts cost 0.6-0.9 s per burst and changed no ideal burst.
  // The restarts depend on the measured state only, so they run side by side;
  // each is then judged in order against the best so far.
  void Restart(const BundleAdjustmentOptions& adjust, AdjustmentAttempt* attempt) const {
    const SparseState measured = attempt->state;
    std::vector<double> starts = {measured.readout};
    for (const double start : kReadoutStarts)
      if (std::none_of(starts.begin(), starts.end(),
                       [&](double tried) { return std::abs(tried - start) < kSameReadoutStart; }))
        starts.push_back(start);
    std::vector<AdjustmentAttempt> restarts(starts.size());
    std::vector<double> errors(starts.size(), std::numeric_limits<double>::infinity());
    std::vector<std::function<void()>> tasks;
    for (size_t k = 0; k < starts.size(); ++k)
      tasks.push_back([&, k] {
        if (!RectifiedStart(measured.camera, measured.poses, starts[k], &restarts[k])) return;
        restarts[k].Adjust(tracks_, adjust);
        errors[k] = MedianTrackError(tracks_, restarts[k].state);
      });
    RunInParallel(tasks);
    double best_error = MedianTrackError(tracks_, attempt->state);
    std::vector<StartRecord> records;
    std::optional<size_t> chosen;
    for (size_t k = 0; k < starts.size(); ++k) {
      AdjustmentAttempt& restart = restarts[k];
      restart.start_f = measured.camera.f;
      const bool rectified = !restart.runs.empty();
      records.push_back(Record(StartKind::kReadout, restart,
                               rectified ? errors[k] : std::numeric_limits<double>::quiet_NaN(),
                               rectified ? StartOutcome::kBeaten : StartOutcome::kFailed));
      records.back().start_readout = starts[k];
      if (!rectified) {
        records.back().error = "no rectified rank-1 start with enough consistent tracks";
        continue;
      }
      attempt->runs.insert(attempt->runs.end(), restart.runs.begin(), restart.runs.end());
      if (errors[k] < best_error) {
        best_error = errors[k];
        chosen = records.size() - 1;
        attempt->state = std::move(restart.state);
        attempt->use = std::move(restart.use);
        attempt->summary = std::move(restart.summary);
        attempt->rank_one = std::move(restart.rank_one);
      }
    }
    if (chosen) records[*chosen].outcome = StartOutcome::kChosen;
    attempt->starts.insert(attempt->starts.end(), records.begin(), records.end());
  }

  const FeatureTracks& tracks_;
  const SparseOptions& options_;
  const bool rank_one_;
};

}  // namespace

void AdjustmentAttempt::Adjust(const FeatureTracks& tracks,
                               const BundleAdjustmentOptions& options) {
  if (weights.empty()) {
    summary = RunBundleAdjustment(tracks, use, &state, options);
  } else {
    FeatureTracks weighted = tracks;
    weighted.weights = weights;
    summary = RunBundleAdjustment(weighted, use, &state, options);
  }
  BundleAdjustmentRun run;
  run.iterations = summary.iterations;
  run.converged = summary.converged;
  run.tracks = CountUsed(use);
  run.final_cost = summary.final_cost;
  runs.push_back(run);
}

namespace {

// One start of the adjustment: how it is made, where it starts, and whether
// it is probed (its first adjustment capped at kProbeIterations, on at most
// kProbeTracks of its tracks) rather than run in full.
struct PlannedStart {
  StartKind kind = StartKind::kFocal;
  double start_f = 0.0;  // pixels
  bool probe = false;
};

// The starts, in the order they are judged: the focal starts (the paper's
// guess first, in full; SparseOptions::focal_starts, self-calibration only),
// the naive probe (SparseOptions::naive_probe), then the given start. With
// options.init kNaive, one naive start in full; a given start with turning
// rows, alone and in full.
std::vector<PlannedStart> PlanStarts(const CameraModel& initial, const SparseOptions& options,
                                     const GivenStart* given) {
  if (given && given->turning_rows) return {{StartKind::kGiven, initial.f, false}};
  const bool rank_one = options.init == InitMode::kRankOne;
  std::vector<PlannedStart> plan;
  const bool self_calibrating = !options.known && rank_one;
  const size_t focal = self_calibrating ? options.focal_starts.size() : 1;
  for (size_t n = 0; n < focal; ++n) {
    const double f = self_calibrating ? options.focal_starts[n] * initial.f : initial.f;
    plan.push_back({rank_one ? StartKind::kFocal : StartKind::kNaive, f, n > 0});
  }
  if (rank_one && options.naive_probe) plan.push_back({StartKind::kNaive, plan[0].start_f, true});
  if (given) plan.push_back({StartKind::kGiven, initial.f, true});
  return plan;
}

// The start a solution is kept from: a later start replaces the solution so
// far only where it fits every track clearly better (kLaterStartGain); a
// start that found no solution is passed over. Records each start's cost and
// outcome in `records`, in the plan's order.
std::optional<size_t> ChooseStart(const FeatureTracks& tracks,
                                  const std::vector<AdjustmentAttempt>& attempts,
                                  const std::vector<std::optional<ReconstructionError>>& errors,
                                  const std::vector<PlannedStart>& plan,
                                  const SparseOptions& options, std::vector<StartRecord>* records) {
  std::optional<size_t> best;
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<double> costs(plan.size(), std::numeric_limits<double>::quiet_NaN());
  for (size_t n = 0; n < plan.size(); ++n) {
    if (errors[n]) continue;
    costs[n] = TruncatedTrackCost(tracks, attempts[n].state, options.outlier_px);
    if (!best || costs[n] < (1.0 - kLaterStartGain) * best_cost) best = n, best_cost = costs[n];
  }
  for (size_t n = 0; n < plan.size(); ++n) {
    const StartOutcome outcome = errors[n]   ? StartOutcome::kFailed
                                 : n == best ? StartOutcome::kChosen
                                             : StartOutcome::kBeaten;
    records->push_back(Record(plan[n].kind, attempts[n], costs[n], outcome));
    if (errors[n]) records->back().error = errors[n]->what();
  }
  return best;
}

}  // namespace

AdjustmentAttempt AdjustFromStarts(const FeatureTracks& tracks, const CameraModel& initial,
                                   const SparseOptions& options,
                                   const BundleAdjustmentOptions& adjust, StageTimer* timer,
                                   SharedWork* beside, const GivenStart* given) {
  const StartedAdjustment steps(tracks, options);
  SparseOptions naive_options = options;
  naive_options.init = InitMode::kNaive;
  const StartedAdjustment naive_steps(tracks, naive_options);
  // Each start is initialized and adjusted once, side by side: the first
  // (timed) to the end of its first adjustment, a later one probed.
  const std::vector<PlannedStart> plan = PlanStarts(initial, options, given);
  const size_t starts = plan.size();
  // The steps of a start, by how it was made (AdjustmentAttempt::init).
  // A given start finishes as a naive one: without the readout restarts,
  // which its own adjustment has been through.
  const auto steps_for = [&](const AdjustmentAttempt& attempt) -> const StartedAdjustment& {
    return attempt.init == InitMode::kNaive || attempt.given ? naive_steps : steps;
  };
  std::vector<AdjustmentAttempt> attempts(starts);
  std::vector<std::optional<ReconstructionError>> errors(starts);
  std::vector<int> measured_iterations(starts, 0);
  std::vector<std::chrono::steady_clock::time_point> done(starts);
  bool first_finished = false;
  // Pieces only fill a core another start leaves idle: with one start, or
  // one thread (the starts then run one after the other), there is none.
  const bool helped =
      starts > 1 && cv::getNumThreads() > 1 && beside && beside->taken() < beside->size();
  std::atomic<int> running(static_cast<int>(starts));
  std::vector<std::function<void()>> tasks;
  for (size_t n = 0; n < starts; ++n)
    tasks.push_back([&, n] {
      CameraModel start = initial;
      start.f = plan[n].start_f;
      AdjustmentAttempt& attempt = attempts[n];
      attempt.start_f = start.f;
      attempt.init = plan[n].kind == StartKind::kFocal ? InitMode::kRankOne : InitMode::kNaive;
      BundleAdjustmentOptions probe = adjust;
      if (plan[n].probe) probe.max_iterations = std::min(probe.max_iterations, kProbeIterations);
      try {
        if (plan[n].kind == StartKind::kGiven) {
          // Probed from where it stands: its camera replaced by the initial
          // one (the known camera), its readout kept as the adjustment's start.
          attempt.state = given->state;
          attempt.state.camera = initial;
          attempt.use = given->use;
          attempt.init = given->init;
          attempt.given = true;
          attempt.Adjust(tracks, probe);
          measured_iterations[n] = probe.max_iterations;
        } else {
          measured_iterations[n] = steps_for(attempt).Solve(
              start, probe, n == 0 ? timer : nullptr, &attempt,
              plan[n].probe ? std::max(kProbeTracks, options.min_tracks) : 0);
        }
        // The first start's finish depends on no other start, so it runs
        // here, beside the probes, unless it restarts from several readouts
        // (those restarts run side by side after the probes, with the cores
        // to themselves: a parallel region inside this one would run serially).
        if (n == 0) {
          steps_for(attempt).Continue(adjust, measured_iterations[0], &attempt);
          if (!steps_for(attempt).Restarts(adjust, attempt)) {
            steps_for(attempt).Settle(adjust, &attempt);
            first_finished = true;
          }
        }
      } catch (const ReconstructionError& error) {
        errors[n] = error;
      }
      done[n] = std::chrono::steady_clock::now();
      // A start that is done takes up the caller's pieces while another
      // still runs (the probe outlasts the first start by up to ~190 ms at
      // 1080p); the last one to finish takes none: the caller's Finish then
      // spreads what is left over every core.
      const int still_running = --running;
      if (helped && still_running > 0) beside->Help([&running] { return running.load() > 0; });
    });
  RunInParallel(tasks);
  const auto region_end = std::chrono::steady_clock::now();
  // The time the later starts kept the first one waiting is theirs; the time
  // the caller's work kept the region open after every start was done, its own.
  const auto starts_end = *std::max_element(done.begin(), done.end());
  const double waited_ms = MillisecondsBetween(done[0], starts_end);
  const double beside_ms = helped ? MillisecondsBetween(starts_end, region_end) : 0.0;
  if (!errors[0] && !first_finished) {
    try {
      steps_for(attempts[0]).Settle(adjust, &attempts[0]);
    } catch (const ReconstructionError& error) {
      errors[0] = error;
    }
  }
  LapIfTimed(timer, "bundle_adjustment", starts > 1 ? waited_ms + beside_ms : 0.0);
  // The region's end less its carried wait: the pieces' time after every
  // start was done; the wait goes on to later_starts.
  if (helped) LapIfTimed(timer, "beside_starts", waited_ms);

  // One record per start, in the plan's order, then the chosen one's
  // readout restarts.
  std::vector<StartRecord> records;
  const std::optional<size_t> best = ChooseStart(tracks, attempts, errors, plan, options, &records);
  if (!best) throw *errors[0];
  AdjustmentAttempt solved = std::move(attempts[*best]);
  records.insert(records.end(), solved.starts.begin(), solved.starts.end());
  solved.starts = std::move(records);
  // A probed start that won goes on from there with the whole budget.
  if (*best > 0) steps_for(solved).Finish(adjust, measured_iterations[*best], &solved);
  if (starts > 1) LapIfTimed(timer, "later_starts");
  steps_for(solved).Reweight(adjust, &solved);
  LapIfTimed(timer, "reweight");
  return solved;
}

}  // namespace dfsm
