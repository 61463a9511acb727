// The calibration of one camera from many bursts: each burst's estimate of
// (f, k1, k2) weighted by its information (the inverse of its covariance,
// core/sparse/calibration_uncertainty.h). The state is the information matrix
// Lambda = sum C_i^-1 and the information vector eta = sum C_i^-1 theta_i, so
// adding a burst is one exact sum and the fused estimate Lambda^-1 eta does
// not depend on the order the bursts came in.
//
// A burst is fused only when it is consistent with the fusion: its difference
// d from the fused estimate, whose covariance is C + Lambda^-1, passes a
// chi-square gate (3 dof). One burst that fails is an outlier (a gross failure
// of one self-calibration must not reset a good fusion); a second failing
// burst in a row that agrees with the first says the camera itself changed
// (zoom, refocus, lens swap), and the fusion restarts from those two.
//
// It lives in core, not beside the daemon, because `dfsm calibrate`
// (tools/dfsm/calibrate_command.cc) fuses bursts without a daemon; dfsmd's
// CalibrationKeeper (daemon/service) keeps one per camera and image size.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/camera/camera_model.h"

namespace dfsm {

// P(X <= x) for X ~ chi-square with `degrees_of_freedom` (1..1000), through
// the series of the regularized lower incomplete gamma function.
double ChiSquareCdf(double x, int degrees_of_freedom);
// The x with ChiSquareCdf(x) = probability, probability in (0, 1), by bisection.
double ChiSquareQuantile(double probability, int degrees_of_freedom);

// Floors of the fused calibration's widths as a prior (KnownCalibration's
// f_sigma_percent, distortion_sigma_px): its sigma counts each burst's noise,
// not the model error the bursts share, and shrinks like 1 / sqrt(bursts);
// without a floor many bursts would freeze the camera.
constexpr double kMinFusedPriorSigmaFPercent = 0.2;
constexpr double kMinFusedPriorDistortionPx = 0.1;

struct KnownCalibration;  // core/sparse/sparse_reconstruction.h

// A fused camera as the known calibration of a later burst, as dfsmd gives
// it: a prior whose widths are the fusion's (`sigma_f_percent`,
// `distortion_sigma_px`) raised to the floors above; not checked against
// the burst (it was made from this camera's own bursts, with their sigma),
// and the burst calibrated alone beside it for the next fusion.
KnownCalibration FusedCalibrationPrior(const CameraModel& fused, double sigma_f_percent,
                                       double distortion_sigma_px, const std::string& source);

struct CalibrationSample {  // one burst's estimate
  CameraModel camera;       // f, k1, k2 estimated; width, height, cx, cy as used
  // Of (f [px], k1, k2): symmetric positive definite. A burst that held k1, k2
  // fixed has zero rows there and is refused: it says nothing about them.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  std::string job;  // the job id or burst name it came from
  int64_t time_ms = 0;
};

struct SparseReconstruction;  // core/sparse/sparse_reconstruction.h

// The sample a fusion takes of one burst's sparse stage: the burst's own
// calibration (beside a known prior where there was one), less the bias its
// tracks' noise gave it (the fusion averages the bursts' noise out, their
// bias it would keep: core/sparse/bootstrap_bias.h). Nullopt where the burst
// did not estimate the camera, has no uncertainty or is degenerate, with why.
std::optional<CalibrationSample> FusionSampleOf(const SparseReconstruction& sparse,
                                                const std::string& job, std::string* why);

struct CalibrationFusionOptions {
  double consistency_probability = 0.999;  // chi-square (3 dof) gate: 16.27 at 0.999
  int min_bursts_for_reliable = 3;
  // Fused sigma_f below this and fused distortion sigma below the next =>
  // reliable; the thresholds of one burst's verdict (CalibrationQualityOptions).
  double max_reliable_sigma_f_percent = 0.5;
  double max_reliable_distortion_sigma_px = 0.25;
  int history_limit = 100;  // newest entries kept in the history
  // f, k1, k2 mean another camera about another principal point, so samples
  // must share it (and the image size) with the fusion to this tolerance.
  double principal_point_tolerance_px = 1e-3;

  void Check() const;  // throws std::invalid_argument naming the bad field
};

enum class FusionOutcome { kFused, kStarted, kOutlier, kRestartedAfterChange, kRefused };
// "fused", "started", "outlier", "restarted-after-change", "refused"
const char* FusionOutcomeName(FusionOutcome outcome);
std::optional<FusionOutcome> FusionOutcomeFromName(const std::string& name);

class CalibrationFusion {
 public:
  struct HistoryEntry {
    std::string job;
    int64_t time_ms = 0;
    double f = 0.0, k1 = 0.0, k2 = 0.0;  // the sample's (NaN where it had none)
    double sigma_f_percent = 0.0;        // the sample's
    FusionOutcome outcome = FusionOutcome::kRefused;
    std::string reason;  // what Add reported
    // Against the fusion before the sample; NaN when not tested (started, refused).
    double chi2 = 0.0;
    int fused_bursts_after = 0;
    double fused_f_after = 0.0;  // NaN when the fusion is empty
  };
  // Lifetime counts of Add's outcomes (Reset keeps them, as it keeps the history).
  struct Counts {
    int started = 0, fused = 0, outliers = 0, restarts = 0, refused = 0;
  };

  explicit CalibrationFusion(CalibrationFusionOptions options = {});

  // Adds one burst and says what became of it; `reason` gets a sentence for
  // the outcome (why refused, the chi-square against the gate), empty for
  // kStarted. A refused sample leaves the fusion and a pending outlier as they
  // were: it is no evidence of a change.
  FusionOutcome Add(const CalibrationSample& sample, std::string* reason = nullptr);
  // Forgets the fusion and a pending outlier; the history and counts stay.
  void Reset();

  int bursts() const { return bursts_; }  // samples in the current fusion
  bool empty() const { return bursts_ == 0; }
  // The fused estimate and its covariance Lambda^-1. These four throw
  // std::logic_error when empty().
  CameraModel camera() const;  // fused f, k1, k2 with the samples' size and principal point
  Eigen::Matrix3d covariance() const;
  double sigma_f_percent() const;
  double distortion_sigma_px() const;  // mean over the image (PropagateToDistortion)
  // bursts() >= min_bursts_for_reliable and both sigmas under their thresholds.
  bool reliable() const;
  // What keeps it from being reliable, one sentence per condition it misses
  // ("2 of 3 bursts", ...); empty when reliable.
  std::vector<std::string> UnreliableReasons() const;

  double consistency_gate() const { return gate_; }  // the chi-square quantile
  // The last burst that failed the gate, waiting for a second one like it.
  const std::optional<CalibrationSample>& pending_outlier() const { return pending_; }
  const std::vector<HistoryEntry>& history() const { return history_; }
  const Counts& counts() const { return counts_; }
  const CalibrationFusionOptions& options() const { return options_; }

  // The state, exactly (information matrix and vector, image geometry, pending
  // outlier, history, counts), plus readable fields: "empty", "bursts",
  // "reliable", "camera" (ToJson(CameraModel)), "sigma_f_percent", "sigma_k1",
  // "sigma_k2", "distortion_sigma_px", "covariance", "consistency_gate_chi2".
  // Numbers that are not finite are written as null.
  nlohmann::json ToJson() const;
  // Restores ToJson's state under `options` (a longer history is cut to
  // history_limit). Throws std::runtime_error naming the bad field.
  static CalibrationFusion FromJson(const nlohmann::json& j, CalibrationFusionOptions options = {});

 private:
  Eigen::Vector3d Mean() const;
  void Accumulate(const Eigen::Vector3d& theta, const Eigen::Matrix3d& information);
  void Record(const CalibrationSample& sample, FusionOutcome outcome, const std::string& reason,
              double chi2);

  CalibrationFusionOptions options_;
  double gate_ = 0.0;
  int bursts_ = 0;
  Eigen::Matrix3d information_ = Eigen::Matrix3d::Zero();         // Lambda
  Eigen::Vector3d information_vector_ = Eigen::Vector3d::Zero();  // eta
  CameraModel geometry_;  // width, height, cx, cy of the fused samples (when !empty())
  std::optional<CalibrationSample> pending_;
  std::vector<HistoryEntry> history_;
  Counts counts_;
};

}  // namespace dfsm
