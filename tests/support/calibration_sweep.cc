#include "tests/support/calibration_sweep.h"

#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>

#include "core/pipeline/evaluation.h"
#include "core/pipeline/pipeline.h"

namespace dfsm {

SweepFieldOfView ParseSweepFieldOfView(const std::string& name) {
  if (name == "normal") return SweepFieldOfView::kNormal;
  if (name == "wide") return SweepFieldOfView::kWide;
  throw std::invalid_argument("field of view '" + name + "': expected normal or wide");
}

const std::vector<SweepSize>& SweepSizes() {
  static const std::vector<SweepSize> sizes = {{320, 240}, {640, 480}, {1280, 720}, {1920, 1080}};
  return sizes;
}

SweepMotion ParseSweepMotion(const std::string& name) {
  if (name == "tremor") return SweepMotion::kTremor;
  if (name == "rotation") return SweepMotion::kRotation;
  throw std::invalid_argument("motion '" + name + "': expected tremor or rotation");
}

const std::vector<double>& SweepTremors(SweepMotion motion) {
  static const std::vector<double> tremors = {0.25, 0.5, 1.0, 2.0};
  static const std::vector<double> rotations = {1.0, 2.0, 4.0, 6.0};
  return motion == SweepMotion::kRotation ? rotations : tremors;
}

std::vector<SynthOptions> DefaultStrengthSettings(int seeds, const std::string& camera) {
  if (seeds < 1) throw std::invalid_argument("DefaultStrengthSettings: seeds must be >= 1");
  const CameraEffects effects = CameraEffects::Preset(camera);
  const int jpeg_quality = CameraEffects::PresetJpegQuality(camera);
  std::vector<SynthOptions> settings;
  for (const SweepSize& size : SweepSizes())
    for (int seed = 1; seed <= seeds; ++seed) {
      SynthOptions options;
      options.width = size.width;
      options.height = size.height;
      options.effects = effects;
      options.jpeg_quality = jpeg_quality;
      options.seed = static_cast<uint64_t>(seed);
      settings.push_back(options);
    }
  return settings;
}

std::vector<SynthOptions> CalibrationSweepSettings(int count, uint64_t seed,
                                                   SweepFieldOfView field_of_view,
                                                   const CameraEffects& effects,
                                                   SweepMotion motion) {
  // f over the longer side; the normal range is the one the sweep always had,
  // the wide one ends where it begins.
  constexpr double kNormalLow = 0.8, kNormalHigh = 1.5, kWideLow = 0.55;
  const bool wide = field_of_view == SweepFieldOfView::kWide;
  const double f_low = wide ? kWideLow : kNormalLow;
  const double f_high = wide ? kNormalLow : kNormalHigh;
  const std::vector<SweepSize>& sizes = SweepSizes();
  const std::vector<double>& tremors = SweepTremors(motion);
  // Baselines in metres: the range's low end and width.
  const double baseline_low = motion == SweepMotion::kRotation ? 0.001 : 0.003;
  const double baseline_width = motion == SweepMotion::kRotation ? 0.009 : 0.007;
  std::mt19937_64 random(seed);
  std::mt19937_64 redraw(seed + 0x9e3779b97f4a7c15ull);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<SynthOptions> settings;
  for (int i = 0; i < count; ++i) {
    SynthOptions options;
    options.width = sizes[i % sizes.size()].width;
    options.height = sizes[i % sizes.size()].height;
    options.rotation_deg = tremors[(i / sizes.size()) % tremors.size()];
    options.baseline = baseline_low + baseline_width * uniform(random);
    // k1 -0.3..0.3 and k2 of the opposite sign, up to a third of its size (as
    // fitted real lenses tend to have) at the normal range's widest lens, f
    // 0.8 x; a wider lens gets the same shift of its corner (k1 r^2, k2 r^4
    // as there) rather than the same k1, which would fold a barrel lens over
    // itself. A lens that the effects' k3 still folds is drawn again. (The
    // order of the draws is the one the normal sweep always had.)
    const double longer = std::max(options.width, options.height);
    double k1_draw = uniform(random), k2_draw = uniform(random);
    options.f = longer * (f_low + (f_high - f_low) * uniform(random));
    options.effects = effects;
    const double scale = std::pow(std::min(1.0, options.f / (kNormalLow * longer)), 2);
    for (;;) {
      options.k1 = scale * (-0.3 + 0.6 * k1_draw);
      options.k2 = -options.k1 * scale * k2_draw / 3.0;
      if (RenderedLensIsInvertible(options)) break;
      // From a generator of its own, so that the bursts after this one keep
      // the draws they have in the other fields of view.
      k1_draw = uniform(redraw);
      k2_draw = uniform(redraw);
    }
    options.jpeg_quality = uniform(random) < 0.5 ? 0 : 85;
    options.frames = uniform(random) < 0.5 ? 10 : 15;
    options.supersampling = 2;
    options.seed = seed * 1000 + i;
    settings.push_back(options);
  }
  return settings;
}

bool SweepOutcome::f_within_2_sigma() const {
  return sigma_f_percent > 0.0 && std::abs(f_error_percent) <= 2.0 * sigma_f_percent;
}
bool SweepOutcome::distortion_within_2_sigma() const {
  return distortion_sigma_px > 0.0 && distortion_error_px <= 2.0 * distortion_sigma_px;
}

SweepOutcome RunSweepBurst(const SynthOptions& settings, const SparseOptions& options) {
  SweepOutcome outcome;
  outcome.settings = settings;
  const SynthBurst burst = SynthesizeBurst(settings);
  const Burst frames = ToBurst(burst);
  PipelineOptions pipeline;
  pipeline.sparse = options;
  const auto start = std::chrono::steady_clock::now();
  try {
    const SparseReconstruction sparse = ReconstructSparseStage(frames, pipeline);
    outcome.reconstructed = true;
    const CameraModel& camera =
        sparse.rejected_camera ? *sparse.rejected_camera : sparse.state.camera;
    outcome.f_error_percent = 100.0 * (camera.f - burst.truth.camera.f) / burst.truth.camera.f;
    outcome.distortion_error_px = MeanDistortionError(camera, burst.truth.camera);
    const CameraModel debiased = sparse.DebiasedCamera().value_or(camera);
    outcome.debiased_f_error_percent =
        100.0 * (debiased.f - burst.truth.camera.f) / burst.truth.camera.f;
    outcome.debiased_distortion_error_px = MeanDistortionError(debiased, burst.truth.camera);
    outcome.sigma_f_percent = sparse.uncertainty.available
                                  ? sparse.uncertainty.sigma_f_percent(sparse.state.camera.f)
                                  : 0.0;
    outcome.distortion_sigma_px = sparse.uncertainty.distortion_sigma_px;
    outcome.quality = CalibrationQualityName(sparse.verdict.quality);
    outcome.reasons = sparse.verdict.reasons;
    outcome.frames_left_out = static_cast<int>(sparse.feature_stats.left_out.size());
  } catch (const ReconstructionError& e) {
    outcome.error = e.what();
  }
  outcome.sparse_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return outcome;
}

nlohmann::json SweepSettingsJson(const SynthOptions& settings) {
  return {{"width", settings.width},
          {"height", settings.height},
          {"frames", settings.frames},
          {"rotation_deg", settings.rotation_deg},
          {"baseline_mm", 1000.0 * settings.baseline},
          {"f_true", settings.f},
          {"k1", settings.k1},
          {"k2", settings.k2},
          {"jpeg", settings.jpeg_quality},
          {"hand_path", settings.hand_path},
          {"seed", settings.seed}};
}

nlohmann::json ToJson(const SweepOutcome& o) {
  nlohmann::json j = SweepSettingsJson(o.settings);
  j["reconstructed"] = o.reconstructed;
  j["sparse_ms"] = o.sparse_ms;
  if (!o.reconstructed) {
    j["error"] = o.error;
    return j;
  }
  j.update({{"frames_left_out", o.frames_left_out},
            {"f_error_percent", o.f_error_percent},
            {"sigma_f_percent", o.sigma_f_percent},
            {"distortion_error_px", o.distortion_error_px},
            {"distortion_sigma_px", o.distortion_sigma_px},
            {"debiased_f_error_percent", o.debiased_f_error_percent},
            {"debiased_distortion_error_px", o.debiased_distortion_error_px},
            {"quality", o.quality},
            {"reasons", o.reasons}});
  return j;
}

SweepSummary Summarize(const std::vector<SweepOutcome>& outcomes) {
  SweepSummary s;
  int f_in = 0, d_in = 0;
  for (const SweepOutcome& o : outcomes) {
    ++s.bursts;
    if (!o.reconstructed) continue;
    ++s.reconstructed;
    f_in += o.f_within_2_sigma();
    d_in += o.distortion_within_2_sigma();
    if (o.quality == "reliable") {
      ++s.reliable;
      s.reliable_max_f_error_percent =
          std::max(s.reliable_max_f_error_percent, std::abs(o.f_error_percent));
      s.reliable_max_distortion_error_px =
          std::max(s.reliable_max_distortion_error_px, o.distortion_error_px);
      s.over_5_percent_called_reliable += std::abs(o.f_error_percent) > 5.0;
    } else if (o.quality == "uncertain") {
      ++s.uncertain;
    } else {
      ++s.degenerate;
    }
  }
  if (s.reconstructed > 0) {
    s.f_within_2_sigma = double(f_in) / s.reconstructed;
    s.distortion_within_2_sigma = double(d_in) / s.reconstructed;
  }
  return s;
}

nlohmann::json ToJson(const SweepSummary& s) {
  return {{"bursts", s.bursts},
          {"reconstructed", s.reconstructed},
          {"f_within_2_sigma", s.f_within_2_sigma},
          {"distortion_within_2_sigma", s.distortion_within_2_sigma},
          {"reliable", s.reliable},
          {"uncertain", s.uncertain},
          {"degenerate", s.degenerate},
          {"reliable_max_f_error_percent", s.reliable_max_f_error_percent},
          {"reliable_max_distortion_error_px", s.reliable_max_distortion_error_px},
          {"over_5_percent_called_reliable", s.over_5_percent_called_reliable}};
}

}  // namespace dfsm
