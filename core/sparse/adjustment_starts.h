// The self-calibrating adjustment from its starts (steps 2-4 of Ha et al.
// 2016, with the rolling shutter of Im et al. 2015): from each focal start,
// the rotations, the rank-1 initialization (rectified for a readout), the
// first adjustment; then the readout restarts and the outlier rounds; beside
// them the naive start (SparseOptions::naive_probe); the start that fits every
// track best, each track at its best depth under the start's geometry, is
// kept (SparseOptions::focal_starts). A probe adjusts a share of the tracks
// and, where it wins, takes in the others before it goes on. The winner's
// tracks are then reweighted.
//
// Starts, and readout restarts, that do not depend on each other run side by
// side on OpenCV's thread pool: the later starts' probes beside the first
// start's initialization and its whole adjustment (its first adjustment only,
// where readout restarts follow: they run side by side after the probes). Each adjustment itself is
// single-threaded and the winner is chosen in the starts' order, so the result is the same on one
// core as on four.
#pragma once

#include <vector>

#include "core/io/stage_timer.h"
#include "core/parallel/shared_work.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {

// A readout below this (frame intervals) moves no observation by a tenth of a
// pixel at a degree of tremor: the rank-1 start is not rectified for it, no
// readout restarts follow, and a self-calibration is not refined with each
// frame's angular velocity (sparse_reconstruction.cc).
inline constexpr double kMinEffectiveReadout = 0.05;

// One path from a start to an adjusted solution: what it reached and how.
struct AdjustmentAttempt {
  SparseState state;
  std::vector<bool> use;  // the tracks it adjusts
  // Per track, the weight the reweighting rounds gave it (FeatureTracks::
  // weights); empty before them.
  std::vector<double> weights;
  // Of the last adjustment it kept; after outlier rounds, initial_cost is the
  // one before the rounds.
  BundleAdjustmentSummary summary;
  RankOneResult rank_one;  // the initialization it came from (rank1 mode)
  // Every adjustment it ran, in order: restarts it did not keep included.
  std::vector<BundleAdjustmentRun> runs;
  double start_f = 0.0;                // the focal length it started from, pixels
  InitMode init = InitMode::kRankOne;  // its start: rank-1, or naive (the probe)
  bool given = false;                  // it started from a GivenStart (of `init`)
  // A probe adjusts a share of its tracks (kProbeTracks in
  // adjustment_starts.cc): the ones it would have adjusted, `use` before the
  // thinning; empty where it adjusted them all.
  std::vector<bool> thinned_from;
  // The starts decided on the way to it: AdjustFromStarts's, then its own
  // readout restarts.
  std::vector<StartRecord> starts;

  // One adjustment of the `use` tracks from `state`, in place, recorded in
  // `summary` and `runs`; `tracks` weighted by `weights` where it has them.
  void Adjust(const FeatureTracks& tracks, const BundleAdjustmentOptions& options);
};

// A solution to start from beside the starts AdjustFromStarts makes itself:
// the burst's own calibration, given to the adjustment under a known one
// (ReconstructSparse). Its camera is replaced by the adjustment's initial one.
struct GivenStart {
  SparseState state;
  std::vector<bool> use;
  InitMode init = InitMode::kRankOne;  // how the given solution itself started
  // The only start, its rows turning at each frame's own angular velocity
  // (SparseOptions::angular_velocity_sigma_px): a self-calibrated solution
  // on the line between frame poses, refined; its camera is the initial one.
  bool turning_rows = false;
};

// Adjusts `tracks` from `initial` (a known camera, or CameraModel::Initial),
// with `adjust` (options.bundle_adjustment as the known calibration and the
// readout mode set it). A known calibration starts from itself; a burst that
// calibrates itself starts from each of options.focal_starts; with the rank-1
// initialization the naive start is probed as well (options.naive_probe),
// from the first start's camera. options.init kNaive starts once, naively.
// Laps `timer` (where not null) with "rotation", "rank1" and "bundle_adjustment" (the first
// start's) and, with more than one start, "later_starts": the wall time the
// later starts add (a wait for them after the first start, and the winner's
// rest where a later start wins); then "reweight": its reweighting rounds
// (SparseOptions::reweight_rounds; AdjustmentAttempt::weights). Throws
// ReconstructionError, with the first start's reason, where no start reaches
// a solution; std::invalid_argument for options SparseOptions::Check refuses.
//
// `beside` (may be null): pieces of the caller's work that do not depend on
// this one (ReconstructSparse's). With more than one start and more than one
// thread, a start that is done takes pieces up while another start still
// runs, filling the core the first start leaves idle beside the probes; the
// time a piece taken last keeps the starts' region open is lapped as
// "beside_starts". Pieces not taken (SharedWork::taken), the caller runs.
//
// `given` (may be null): one start more, probed and compared like the naive
// one (AdjustmentAttempt::given says it won).
AdjustmentAttempt AdjustFromStarts(const FeatureTracks& tracks, const CameraModel& initial,
                                   const SparseOptions& options,
                                   const BundleAdjustmentOptions& adjust, StageTimer* timer,
                                   SharedWork* beside = nullptr, const GivenStart* given = nullptr);

}  // namespace dfsm
