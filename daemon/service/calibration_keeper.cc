#include "daemon/service/calibration_keeper.h"

#include <cmath>

#include "core/camera/camera_model.h"
#include "core/export/calibration_import.h"
#include "core/io/bounded_json.h"
#include "core/io/file_util.h"
#include "core/sparse/calibration_fusion.h"
#include "core/sparse/joint_adjustment.h"
#include "core/sparse/sparse_reconstruction.h"

namespace dfsm::service {
namespace fs = std::filesystem;
namespace {

// fusion.json holds every fusion under its key; a file of one fusion (no
// "format") is what dfsmd stored before fusions were kept per size.
constexpr const char* kFusionsFormat = "dfsm-calibration-fusions/1";

}  // namespace

bool FromCaptureCamera(const JobOptions& options) { return options.camera == "capture"; }

CalibrationKeeper::CalibrationKeeper(const CalibrationSection& config, std::string camera,
                                     const fs::path& state_dir)
    : config_(config),
      camera_(std::move(camera)),
      path_(state_dir / "calibration" / "fusion.json"),
      joint_(state_dir, config.joint_bursts, config.joint_every) {
  if (!config_.file.empty()) {
    try {
      // The size comes from the file: jobs of another size calibrate alone.
      const ImportedCalibration imported = ReadCalibrationFile(config_.file, 0, 0);
      file_camera_ = std::make_unique<CameraModel>(imported.camera);
      if (imported.lens) file_lens_ = std::make_unique<OpenCvLens>(*imported.lens);
      file_source_ = "file:" + config_.file.string() + " (" + imported.format + ")";
      notes_ = imported.notes;
    } catch (const CalibrationFileError& e) {
      throw ConfigError(std::string("calibration.file: ") + e.what());
    }
  }
  std::error_code error;
  if (!fs::exists(path_, error)) return;
  try {
    Load();
  } catch (const std::exception& e) {
    const fs::path aside = path_.string() + ".damaged";
    fs::rename(path_, aside, error);
    notes_.push_back("the stored fusion was unreadable (" + std::string(e.what()) + "); moved to " +
                     aside.filename().string() + ", fusion restarted");
    fusions_.clear();
    current_.clear();
  }
}

CalibrationKeeper::~CalibrationKeeper() = default;

std::string CalibrationKeeper::Key(int width, int height) const {
  return camera_ + " " + std::to_string(width) + "x" + std::to_string(height);
}

void CalibrationKeeper::Load() {
  const nlohmann::json stored = ParseBoundedJson(ReadFileToString(path_));
  if (stored.value("format", "") != kFusionsFormat) {
    auto fusion = std::make_unique<CalibrationFusion>(CalibrationFusion::FromJson(stored));
    current_ = fusion->empty() ? camera_ + " (size not recorded)"
                               : Key(fusion->camera().width, fusion->camera().height);
    fusions_[current_] = std::move(fusion);
    return;
  }
  for (const auto& [key, fusion] : stored.at("fusions").items())
    fusions_[key] = std::make_unique<CalibrationFusion>(CalibrationFusion::FromJson(fusion));
  current_ = stored.value("current", "");
}

bool CalibrationKeeper::ForJob(const JobOptions& options, int width, int height,
                               KnownCalibration* known) const {
  if (options.calibration == "self" || !FromCaptureCamera(options)) return false;
  if (file_camera_ && file_camera_->width == width && file_camera_->height == height) {
    known->camera = *file_camera_;
    if (file_lens_) known->lens = *file_lens_;
    known->mode = ParseKnownCalibrationMode(config_.mode);
    known->source = file_source_;
    known->also_self_calibrate = config_.fuse && known->mode == KnownCalibrationMode::kPrior;
    return true;
  }
  if (config_.use_fused != "prior") return false;
  // The joint calibration first: made from the tracks of several jobs, it
  // observes the camera where single jobs could not.
  if (const std::optional<nlohmann::json> joint = joint_.Reliable(Key(width, height))) {
    std::string unused;
    if (std::optional<KnownCalibration> prior = JointCalibrationPrior(*joint, &unused)) {
      *known = *prior;
      return true;
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = fusions_.find(Key(width, height));
  if (found == fusions_.end()) return false;
  const CalibrationFusion& fusion = *found->second;
  if (fusion.empty() || !fusion.reliable()) return false;
  // The fusion's own sigma: it knows f and the distortion this well.
  *known =
      FusedCalibrationPrior(fusion.camera(), fusion.sigma_f_percent(), fusion.distortion_sigma_px(),
                            "fused (" + std::to_string(fusion.bursts()) + " bursts)");
  known->check_fit = true;
  return true;
}

std::string CalibrationKeeper::Record(const std::string& job, const JobOptions& options,
                                      int64_t time_ms, const SparseReconstruction& sparse) {
  if (!config_.fuse) return "fusion off";
  if (!FromCaptureCamera(options))
    return "not fused: an upload feeds the camera's calibration only when its request says it "
           "comes from the capture camera (camera=capture)";
  std::string why;
  std::optional<CalibrationSample> sample = FusionSampleOf(sparse, job, &why);
  if (!sample) return "not fused: " + why;
  sample->time_ms = time_ms;
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string key = Key(sample->camera.width, sample->camera.height);
  std::unique_ptr<CalibrationFusion>& fusion = fusions_[key];
  if (!fusion) fusion = std::make_unique<CalibrationFusion>();
  for (const CalibrationFusion::HistoryEntry& entry : fusion->history()) {
    if (entry.job == job) return "already counted: the job ran again after an interruption";
  }
  std::string reason;
  const FusionOutcome outcome = fusion->Add(*sample, &reason);
  current_ = key;
  std::string said = FusionOutcomeName(outcome) + (reason.empty() ? "" : ": " + reason);
  try {
    Persist();
  } catch (const std::exception& e) {
    // A full disk: the fusion goes on in memory and is stored with the next job.
    said += " (not stored: " + std::string(e.what()) + ")";
  }
  return said;
}

bool CalibrationKeeper::RememberTracks(const std::string& job, const JobOptions& options, int width,
                                       int height) {
  if (!FromCaptureCamera(options)) return false;
  return joint_.Remember(Key(width, height), job);
}

std::optional<nlohmann::json> CalibrationKeeper::SolveJoint(
    const JointCalibrations::TracksOf& tracks_of) {
  const std::string key = joint_.current();
  if (key.empty()) throw std::runtime_error("no job of the capture camera to calibrate from yet");
  return joint_.TrySolve(key, tracks_of);
}

nlohmann::json CalibrationKeeper::JointSnapshot() const {
  nlohmann::json snapshot = joint_.Snapshot(joint_.current());
  snapshot["notes"] = joint_.notes();
  return snapshot;
}

nlohmann::json CalibrationKeeper::Snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto current = fusions_.find(current_);
  nlohmann::json snapshot =
      current == fusions_.end() ? CalibrationFusion().ToJson() : current->second->ToJson();
  if (current != fusions_.end()) snapshot["key"] = current_;
  nlohmann::json others = nlohmann::json::array();
  for (const auto& [key, fusion] : fusions_) {
    if (key == current_) continue;
    others.push_back({{"key", key},
                      {"bursts", fusion->bursts()},
                      {"reliable", !fusion->empty() && fusion->reliable()}});
  }
  snapshot["other_sizes"] = others;
  snapshot["notes"] = notes_;
  if (file_camera_) snapshot["file"] = {{"source", file_source_}, {"mode", config_.mode}};
  return snapshot;
}

void CalibrationKeeper::Reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& [key, fusion] : fusions_) fusion->Reset();
  Persist();
  joint_.Reset();
}

void CalibrationKeeper::Persist() const {
  nlohmann::json stored = {{"format", kFusionsFormat}, {"current", current_}};
  stored["fusions"] = nlohmann::json::object();
  for (const auto& [key, fusion] : fusions_) stored["fusions"][key] = fusion->ToJson();
  fs::create_directories(path_.parent_path());
  WriteFileAtomically(path_, stored.dump(2) + "\n");
}

}  // namespace dfsm::service
