// The calibration sweep: generated bursts over the settings a user meets
// (320x240-1080p, tremor 0.25-2 deg, baseline 3-10 mm, k1 of either sign, JPEG
// on and off), each self-calibrated and scored against its ground truth, to
// measure whether the reported uncertainty and verdict are honest. Shared by
// bench/calibration_sweep (the docs table) and the long-label test that
// asserts the targets.
#pragma once

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/sparse/sparse_reconstruction.h"
#include "core/synth/burst_synthesizer.h"

namespace dfsm {

// The lens field of view a sweep draws its focal lengths from, as f over the
// longer image side.
enum class SweepFieldOfView {
  kNormal,  // f 0.8-1.5 x the longer side: 37-64 deg across it
  kWide,    // f 0.55-0.8 x: 64-85 deg, the phones' main cameras and most webcams
};
SweepFieldOfView ParseSweepFieldOfView(const std::string& name);  // "normal", "wide"

// The hand motion a sweep draws: tremor (0.25-2 deg over the burst, 3-10 mm
// of baseline), or rotation-dominant (1-6 deg, 1-10 mm: the regime of real
// hand-held windows such as ../shared/data/tum_fr1_rpy).
enum class SweepMotion { kTremor, kRotation };
SweepMotion ParseSweepMotion(const std::string& name);  // "tremor", "rotation"

// The frame sizes the sweeps cycle through, smallest first.
struct SweepSize {
  int width = 0, height = 0;
};
const std::vector<SweepSize>& SweepSizes();
// The tremors (largest rotation against the reference, degrees) the sweeps
// cycle through, smallest first.
const std::vector<double>& SweepTremors(SweepMotion motion = SweepMotion::kTremor);

// The generator at its default strengths (SynthOptions' defaults) with the
// effects and JPEG quality of the camera preset `camera` (CameraEffects::
// Preset, PresetJpegQuality; std::invalid_argument for an unknown name), at
// every SweepSizes() size, seeds 1 to `seeds` (>= 1): the bursts the issue's
// accuracy targets name ("every effect on, default strengths"), where the
// sweeps vary tremor and lens instead.
std::vector<SynthOptions> DefaultStrengthSettings(int seeds, const std::string& camera);

// The settings of burst `index` of a sweep of `count`: every resolution and
// tremor appears equally often, the rest is drawn from `seed` (deterministic;
// the field of view changes the focal lengths and the lens, not the other
// draws; the motion changes the tremors and the baselines' range, not the
// draws). `effects` go into every burst; a lens their k3 would fold is redrawn.
std::vector<SynthOptions> CalibrationSweepSettings(
    int count, uint64_t seed = 1, SweepFieldOfView field_of_view = SweepFieldOfView::kNormal,
    const CameraEffects& effects = {}, SweepMotion motion = SweepMotion::kTremor);

struct SweepOutcome {
  SynthOptions settings;
  bool reconstructed = false;
  std::string error;             // when !reconstructed
  double f_error_percent = 0.0;  // signed
  double sigma_f_percent = 0.0;
  double distortion_error_px = 0.0;
  double distortion_sigma_px = 0.0;
  // The same for the camera less the bias its tracks' noise gave it
  // (SparseReconstruction::DebiasedCamera), what a fusion of bursts takes;
  // equal to the above where no usable bias was measured.
  double debiased_f_error_percent = 0.0;
  double debiased_distortion_error_px = 0.0;
  std::string quality;
  std::vector<std::string> reasons;
  double sparse_ms = 0.0;
  int frames_left_out = 0;  // by the tracker (GridedFeatureStats::left_out)

  // |f error| <= 2 sigma_f, distortion error <= 2 sigma (0 sigma: false).
  bool f_within_2_sigma() const;
  bool distortion_within_2_sigma() const;
};

// A sweep burst's settings as its JSON line names them (f_true: the true f).
nlohmann::json SweepSettingsJson(const SynthOptions& settings);

// The burst `settings` render through the sparse stage as a job runs it
// (ReconstructSparseStage: exposure compensated, frames the tracker loses left
// out), under `options`.
SweepOutcome RunSweepBurst(const SynthOptions& settings, const SparseOptions& options = {});

nlohmann::json ToJson(const SweepOutcome& outcome);

struct SweepSummary {
  int bursts = 0, reconstructed = 0;
  double f_within_2_sigma = 0.0;  // share of reconstructed bursts
  double distortion_within_2_sigma = 0.0;
  int reliable = 0, uncertain = 0, degenerate = 0;
  double reliable_max_f_error_percent = 0.0;
  double reliable_max_distortion_error_px = 0.0;
  int over_5_percent_called_reliable = 0;
};

SweepSummary Summarize(const std::vector<SweepOutcome>& outcomes);
nlohmann::json ToJson(const SweepSummary& summary);

}  // namespace dfsm
