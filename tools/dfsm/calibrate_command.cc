// dfsm calibrate BURST... --out DIR: the calibration of one camera from several
// of its bursts, as dfsmd fuses it (core/sparse/calibration_fusion.h): each
// burst calibrated alone, with its uncertainty and verdict, then fused by
// information weight; a burst inconsistent with the fusion is left out as an
// outlier, two in a row restart it (the camera changed).
#include <cstdio>
#include <nlohmann/json.hpp>

#include "core/export/calibration_export.h"
#include "core/io/file_util.h"
#include "core/sparse/calibration_fusion.h"
#include "core/sparse/sparse_reconstruction.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"

namespace dfsm::tools {

int RunCalibrateCommand(const Args& args) {
  CLI::App app("Calibrates one camera from several of its bursts, as dfsmd fuses them.",
               "dfsm calibrate");
  app.footer(
      "Bursts must share one image size. Exit status: 0 a fused calibration was written, "
      "1 no burst could be fused, 2 usage.");
  std::vector<std::string> bursts;
  std::string out_dir, rolling_shutter = kDefaultRollingShutter;
  ReadBurstOptions read_options;
  app.add_option("BURST", bursts, "dfsm-burst/1 directories of one camera")->required();
  app.add_option("--out", out_dir,
                 "written: calibration.json and calibration.yaml of the fused camera (as 'dfsm "
                 "process' writes them) and fusion.json (the fusion's state, sigma, and each "
                 "burst's estimate and outcome)")
      ->required();
  app.add_option("--frames", read_options.max_frames,
                 "use N frames of each burst, centred on its reference (0: all)")
      ->check(FrameCount());
  app.add_option("--rolling-shutter", rolling_shutter,
                 "global | estimate | R: the sensor's readout, as for 'dfsm process'")
      ->capture_default_str();
  if (const auto status = ParseCommandLine(app, args)) return *status;
  SparseOptions sparse_options;
  try {
    sparse_options.rolling_shutter = ParseRollingShutter(rolling_shutter);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--rolling-shutter: ") + e.what());
  }

  CalibrationFusion fusion;
  for (const std::string& burst_dir : bursts) {
    std::string outcome;
    try {
      const Burst burst = ReadBurst(burst_dir, read_options);
      const SparseReconstruction sparse =
          ReconstructSparse(burst.gray, burst.reference(), sparse_options);
      const CameraModel& camera = sparse.state.camera;
      std::printf("%s: f %.2f px (sigma %.2f %%), k1 %.5f, k2 %.5f, %s", burst_dir.c_str(),
                  camera.f,
                  sparse.uncertainty.available ? sparse.uncertainty.sigma_f_percent(camera.f) : 0.0,
                  camera.k1, camera.k2, CalibrationQualityName(sparse.verdict.quality));
      if (sparse.calibration_used != CalibrationSource::kSelf) {
        outcome = std::string("not fused: ") + CalibrationSourceName(sparse.calibration_used);
      } else if (!sparse.uncertainty.available) {
        outcome = "not fused: " + sparse.uncertainty.unavailable_reason;
      } else if (sparse.verdict.quality == CalibrationQuality::kDegenerate) {
        outcome = "not fused: degenerate (" + sparse.verdict.reasons.front() + ")";
      } else {
        // Less the bias its tracks' noise gave it: fused, the bursts' noise
        // averages out, their bias would not (core/sparse/bootstrap_bias.h).
        CalibrationSample sample;
        sample.camera = sparse.DebiasedCamera().value_or(camera);
        if (sample.camera.f != camera.f)
          std::printf(", less its noise bias f %.2f px", sample.camera.f);
        sample.covariance = sparse.uncertainty.covariance;
        sample.job = burst_dir;
        std::string reason;
        outcome = FusionOutcomeName(fusion.Add(sample, &reason));
        if (!reason.empty()) outcome += ": " + reason;
      }
    } catch (const BurstError& e) {
      std::printf("%s: unreadable", burst_dir.c_str());
      outcome = std::string("not fused: ") + e.what();
    } catch (const ReconstructionError& e) {
      std::printf("%s: failed", burst_dir.c_str());
      outcome = std::string("not fused: ") + e.what();
    }
    std::printf(" -> %s\n", outcome.c_str());
  }
  if (fusion.empty()) {
    std::fprintf(stderr, "dfsm calibrate: no burst could be fused\n");
    return 1;
  }
  std::filesystem::create_directories(out_dir);
  WriteCalibrationFiles(out_dir, fusion.camera());
  WriteFileAtomically(std::filesystem::path(out_dir) / "fusion.json",
                      fusion.ToJson().dump(2) + "\n");
  const CameraModel fused = fusion.camera();
  std::printf(
      "fused       f %.2f px (sigma %.2f %%), k1 %.5f, k2 %.5f, distortion sigma %.2f px, "
      "%d bursts, %s\n",
      fused.f, fusion.sigma_f_percent(), fused.k1, fused.k2, fusion.distortion_sigma_px(),
      fusion.bursts(), fusion.reliable() ? "reliable" : "not yet reliable");
  return 0;
}

}  // namespace dfsm::tools
