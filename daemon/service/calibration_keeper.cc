#include "daemon/service/calibration_keeper.h"

#include <cmath>

#include "core/export/calibration_import.h"
#include "core/io/bounded_json.h"
#include "core/io/file_util.h"
#include "core/sparse/calibration_fusion.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm::service {
namespace fs = std::filesystem;

CalibrationKeeper::CalibrationKeeper(const CalibrationSection& config, const fs::path& state_dir)
    : config_(config),
      path_(state_dir / "calibration" / "fusion.json"),
      fusion_(std::make_unique<CalibrationFusion>()) {
  if (!config_.file.empty()) {
    try {
      // The size comes from the file: jobs of another size calibrate alone.
      const ImportedCalibration imported = ReadCalibrationFile(config_.file, 0, 0);
      file_camera_ = std::make_unique<CameraModel>(imported.camera);
      file_source_ = "file:" + config_.file.string() + " (" + imported.format + ")";
      notes_ = imported.notes;
    } catch (const CalibrationFileError& e) {
      throw ConfigError(std::string("calibration.file: ") + e.what());
    }
  }
  std::error_code error;
  if (!fs::exists(path_, error)) return;
  try {
    *fusion_ = CalibrationFusion::FromJson(ParseBoundedJson(ReadFileToString(path_)));
  } catch (const std::exception& e) {
    const fs::path aside = path_.string() + ".damaged";
    fs::rename(path_, aside, error);
    notes_.push_back("the stored fusion was unreadable (" + std::string(e.what()) + "); moved to " +
                     aside.filename().string() + ", fusion restarted");
    *fusion_ = CalibrationFusion();
  }
}

CalibrationKeeper::~CalibrationKeeper() = default;

bool CalibrationKeeper::ForJob(const JobOptions& options, int width, int height,
                               KnownCalibration* known) const {
  if (options.calibration == "self") return false;
  if (file_camera_ && file_camera_->width == width && file_camera_->height == height) {
    known->camera = *file_camera_;
    known->mode = ParseKnownCalibrationMode(config_.mode);
    known->source = file_source_;
    known->also_self_calibrate = config_.fuse && known->mode == KnownCalibrationMode::kPrior;
    return true;
  }
  if (config_.use_fused != "prior") return false;
  std::lock_guard<std::mutex> lock(mutex_);
  if (fusion_->empty() || !fusion_->reliable()) return false;
  const CameraModel fused = fusion_->camera();
  if (fused.width != width || fused.height != height) return false;  // another mode of the sensor
  // The fusion's own sigma: it knows f and the distortion this well.
  *known = FusedCalibrationPrior(fused, fusion_->sigma_f_percent(), fusion_->distortion_sigma_px(),
                                 "fused (" + std::to_string(fusion_->bursts()) + " bursts)");
  return true;
}

std::string CalibrationKeeper::Record(const std::string& job, int64_t time_ms,
                                      const SparseReconstruction& sparse) {
  if (!config_.fuse) return "fusion off";
  CalibrationSample sample;
  // Each burst's camera less the bias its tracks' noise gave it: the fusion
  // averages the bursts' noise out, their bias it would keep
  // (core/sparse/bootstrap_bias.h). The burst's own calibration: beside a
  // known prior where there is one, else where the burst kept it.
  const std::optional<CameraModel> debiased = sparse.DebiasedCamera();
  if (!debiased) return "not estimated from the burst (" + sparse.calibration_used + ")";
  const CalibrationUncertainty& uncertainty =
      sparse.self_estimate ? sparse.self_estimate->uncertainty : sparse.uncertainty;
  if (!uncertainty.available) return "no uncertainty";
  sample.camera = *debiased;
  sample.covariance = uncertainty.covariance;
  const CalibrationVerdict* verdict =
      sparse.self_estimate ? &sparse.self_estimate->verdict : &sparse.verdict;
  if (verdict->quality == CalibrationQuality::kDegenerate) return "degenerate: not fused";
  sample.job = job;
  sample.time_ms = time_ms;
  std::lock_guard<std::mutex> lock(mutex_);
  std::string reason;
  const FusionOutcome outcome = fusion_->Add(sample, &reason);
  std::string said = FusionOutcomeName(outcome) + (reason.empty() ? "" : ": " + reason);
  try {
    Persist();
  } catch (const std::exception& e) {
    // A full disk: the fusion goes on in memory and is stored with the next job.
    said += " (not stored: " + std::string(e.what()) + ")";
  }
  return said;
}

nlohmann::json CalibrationKeeper::Snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json snapshot = fusion_->ToJson();
  snapshot["notes"] = notes_;
  if (file_camera_) snapshot["file"] = {{"source", file_source_}, {"mode", config_.mode}};
  return snapshot;
}

void CalibrationKeeper::Reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  fusion_->Reset();
  Persist();
}

void CalibrationKeeper::Persist() const {
  fs::create_directories(path_.parent_path());
  WriteFileAtomically(path_, fusion_->ToJson().dump(2) + "\n");
}

}  // namespace dfsm::service
