// Several bursts of one camera adjusted together: one Ceres problem in which
// every burst keeps its own poses and inverse depths (and its own scale
// gauge) while the intrinsics f, k1, k2 and the rolling shutter's readout
// are one parameter block each, shared. As COLMAP shares a camera_id between
// images, the bursts' tracks all inform one camera; a burst too weak to
// calibrate the camera alone (small motion shows f only through second-order
// terms) still adds its information, which a fusion of per-burst estimates
// cannot use: it needs each burst to have observed the camera already.
//
// A burst of another camera or zoom does not fit the shared camera. Each
// joined burst is tested by how far holding its camera at the joint one
// raises its cost over its own minimum (a profile likelihood ratio: the cost
// is re-minimised over its poses and inverse depths, and for the minimum over
// its intrinsics too, from its own camera); the burst that disagrees most is
// left out and the rest adjusted again, until all agree. The bursts are never
// averaged across a disagreement.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"
#include "core/sparse/bootstrap_bias.h"
#include "core/sparse/bundle_adjustment.h"
#include "core/sparse/calibration_quality.h"
#include "core/sparse/calibration_uncertainty.h"
#include "core/sparse/feature_tracks.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {

// One burst as its own sparse stage left it.
struct JointBurst {
  std::string name;
  FeatureTracks tracks;
  std::vector<bool> use;  // the tracks its own adjustment kept
  SparseState state;      // its own solution: its camera and where its poses start
  // Its own tracking noise (the RMS of its residuals, CalibrationUncertainty::
  // residual_sigma_px); 0: unknown, the joint problem's is taken.
  double noise_px = 0.0;
  // Its own sigma of f, percent; 0: unknown. Orders the starts and measures
  // the focal dispersion (JointCalibration::focal_dispersion).
  double sigma_f_percent = 0.0;
};

// The burst `sparse` as the joint adjustment takes it: its tracks (weighed
// alike, as one burst's adjustment of the intrinsics weighs them), its inlier
// tracks, its solution, with its own camera (SparseReconstruction::
// OwnCamera: what its disagreement is measured from), and its noise. Throws
// std::invalid_argument where the burst has no camera of its own.
JointBurst JointBurstOf(const std::string& name, const SparseReconstruction& sparse);

struct JointAdjustmentOptions {
  // The adjustment's settings (loss, priors, budget, readout, covariance
  // inflation) as for one burst; the priors count once for the camera. With
  // hold_inverse_depths, every burst's inverse depths are held (an oracle at
  // depths from elsewhere, bench/joint_calibration.cc): then there is no
  // covariance and no noise bias. Each frame's angular velocity is refused
  // (Check).
  BundleAdjustmentOptions bundle_adjustment;
  CalibrationQualityOptions quality;
  // A burst disagrees where twice the rise of its cost, in units of its
  // inflated noise variance (BundleAdjustmentOptions::uncertainty_inflation
  // as the covariance takes it), exceeds the chi-square quantile of 3
  // degrees of freedom (f, k1, k2) at this probability, as the fusion's gate.
  double consistency_probability = 0.999;
  // A burst is left out only from a round of at least this many: the others,
  // at least 3, give the dispersion it is judged against. With fewer, a
  // disagreement cannot say which burst is the odd one: it is said in the
  // verdict, and every burst stays.
  int min_bursts_to_leave_out = 4;
  // The joint adjustment starts from the camera, among the bursts' own, that
  // fits all of them best; at most this many (the most certain first) are
  // tried.
  int max_starts = 8;
  // Iterations of each burst's adjustment under a camera held fixed (the
  // starts' and the disagreement test's profile costs).
  int profile_iterations = 30;
  // The joint solution's bias from the tracks' noise, measured as for one
  // burst (bootstrap_bias.h) with every joined burst's tracks replicated at
  // once, and taken off the shared camera: joined, the bursts' noise
  // averages out, the bias it gives f does not.
  BootstrapBiasOptions bootstrap;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

// The joint adjustment's options for bursts whose sparse stages ran under
// `sparse`: its adjustment settings, the readout estimated where the rolling
// shutter asks for it, its verdict's thresholds.
JointAdjustmentOptions JointOptionsFor(const SparseOptions& sparse);

enum class JointOutcome { kJoined, kDisagrees };
const char* JointOutcomeName(JointOutcome outcome);  // "joined" | "disagrees"

struct JointBurstResult {
  JointOutcome outcome = JointOutcome::kJoined;
  // 2 (C(joint camera) - C(own minimum)) / (inflated noise variance), C the
  // burst's cost re-minimised over its poses and inverse depths (and its
  // intrinsics for its own minimum, from its own camera), divided by
  // the round's dispersion (the last test it took: a burst left out is
  // tested against the camera of the round that left it out).
  double disagreement = 0.0;
  std::vector<Pose> poses;  // under the joint camera (joined bursts)
  double rms_reprojection_px = 0.0;
  int tracks = 0;  // used in the joint problem
};

struct JointCalibration {
  // The shared camera, less its noise bias where that was measured and
  // usable: the calibration to use.
  CameraModel camera;
  // The camera the joint adjustment fitted, which `bursts`' poses go with.
  CameraModel fitted_camera;
  std::optional<IntrinsicsBias> bias;
  double readout = 0.0;
  // Of the shared intrinsics, from the joint problem, scaled by the
  // dispersions below.
  CalibrationUncertainty uncertainty;
  CalibrationVerdict verdict;
  std::vector<JointBurstResult> bursts;  // in the order given
  double start_f = 0.0;                  // the chosen start's focal length
  // The last round's median disagreement over chi-square(3)'s median, at
  // least 1: how much more than their noise says the bursts disagree, all
  // alike (model error they share). Each burst's disagreement is divided by it.
  double dispersion = 1.0;
  // How much more the joined bursts' own focal lengths scatter about the
  // shared one than their own sigma_f says, at least 1 (`dispersion` where
  // fewer than two have a sigma): the shared f's variance takes it, k1's,
  // k2's and the readout's take `dispersion`.
  double focal_dispersion = 1.0;
  // Fewer bursts than min_bursts_to_leave_out, and one disagreeing beyond
  // the bound: every burst stayed, and the verdict says so.
  bool undecided = false;
  int iterations = 0;  // of the final joint adjustment
  bool converged = false;
  double rms_reprojection_px = 0.0;

  int Joined() const;
};

// Adjusts `bursts` (of one image size) jointly. Throws ReconstructionError
// (sparse_reconstruction.h) where there is none.
JointCalibration AdjustJointly(const std::vector<JointBurst>& bursts,
                               const JointAdjustmentOptions& options = {});

// The joint calibration as `dfsm calibrate`'s joint.json and dfsmd's joint
// result both give it: the shared camera, readout, uncertainty, verdict,
// dispersions and fit, and per burst (`bursts`' names) its outcome and
// disagreement, and where it joined its tracks, RMS and poses.
nlohmann::json ToJson(const JointCalibration& joint, const std::vector<JointBurst>& bursts);

// The prior a joint calibration (as ToJson gives it) is for a later burst of
// its camera: f and distortion within the joint sigma, checked against the
// burst's own fit (KnownCalibration::check_fit); the fused camera's, with its
// sigma, where its "answer" (core/sparse/calibration_choice.h) is the
// fusion's. nullopt, with why, where the joint camera answers and is
// degenerate or has no uncertainty.
std::optional<KnownCalibration> JointCalibrationPrior(const nlohmann::json& joint,
                                                      std::string* why);

}  // namespace dfsm
