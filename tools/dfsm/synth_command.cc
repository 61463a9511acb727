// dfsm synth --out DIR: renders a small-motion burst with ground truth.
#include <cstdio>
#include <optional>
#include <stdexcept>

#include "core/synth/burst_synthesizer.h"
#include "tools/dfsm/command.h"
#include "tools/dfsm/command_line.h"

namespace dfsm::tools {

int RunSynthCommand(const Args& args) {
  CLI::App app(
      "Renders a handheld small-motion burst of a textured 3-D scene (photo-textured slanted "
      "planes in front of a background) through the ha2016-d2u camera model, and writes it as "
      "dfsm-burst/1 with ground_truth.json and depth_gt.tiff.",
      "dfsm synth");
  SynthOptions options;
  std::string out, camera = "ideal";
  bool gray = false;
  app.add_option("--out", out, "burst directory to write")->required();
  app.add_option("--width", options.width, "frame width")->capture_default_str();
  app.add_option("--height", options.height, "frame height")->capture_default_str();
  app.add_option("--frames", options.frames, "frames")->capture_default_str();
  app.add_option("--f", options.f, "focal length in pixels (0: 1.1 * max(W, H))");
  app.add_option("--k1", options.k1, "D->U radial distortion k1")->capture_default_str();
  app.add_option("--k2", options.k2, "D->U radial distortion k2")->capture_default_str();
  app.add_option("--baseline", options.baseline, "extent of the camera path, metres")
      ->capture_default_str();
  app.add_option("--rotation", options.rotation_deg,
                 "largest rotation against the first frame, degrees")
      ->capture_default_str();
  app.add_option("--oscillation", options.oscillation_deg,
                 "a hand's physiological tremor (about 10 Hz at 30 fps) on the orientation, "
                 "degrees per axis at most: the turn bends within a frame's readout")
      ->capture_default_str();
  bool line_path = false;
  CLI::Option* hand = app.add_flag("--hand-path",
                                   "render rows and blur from the hand's own path between frames "
                                   "(the default: it curves, and bends with --oscillation)");
  app.add_flag("--line-path", line_path,
               "render rows and blur on the line between frame poses (the pipeline's own "
               "rolling-shutter model) instead of the hand's path")
      ->excludes(hand);
  app.add_option("--noise", options.noise_sigma, "sensor noise in grey levels")
      ->capture_default_str();
  std::optional<int> jpeg;
  app.add_option("--jpeg", jpeg,
                 "JPEG round trip at quality Q (0: none; default: the --camera preset's, none for "
                 "ideal)");
  app.add_option("--supersampling", options.supersampling, "S x S samples per pixel")
      ->capture_default_str();
  app.add_flag("--gray", gray, "gray8 frames instead of bgr8");
  app.add_option("--seed", options.seed, "scene and motion seed")->capture_default_str();
  app.add_option("--reference", options.reference,
                 "the reference frame: the ground truth's poses are relative to it and "
                 "depth_gt.tiff is its depth (the frames are the same whichever it is)")
      ->capture_default_str();
  app.add_option("--textures", options.texture_dir, "photographs to texture the scene with")
      ->capture_default_str();
  // What a real camera adds (core/synth/camera_effects.h): a preset, then
  // each effect on its own.
  app.add_option("--camera", camera,
                 "preset of the effects below and of --jpeg (ideal: none; webcam: readout 0.8, "
                 "exposure 0.05, white balance 0.02, vignetting 0.2, motion blur 0.5, k3 0.15, "
                 "p1 2e-3, p2 -1.5e-3, shot noise 8, JPEG 80; phone: readout 0.6, exposure 0.12, "
                 "white balance 0.03, vignetting 0.3, motion blur 0.25, k3 -0.05, p1 5e-4, "
                 "p2 5e-4, shot noise 16, JPEG 90)")
      ->check(CLI::IsMember({"ideal", "webcam", "phone"}))
      ->capture_default_str();
  std::optional<double> readout, exposure, white_balance, vignetting;
  app.add_option("--rolling-shutter", readout,
                 "readout time as a fraction of the frame interval (0: global)");
  app.add_option("--exposure-drift", exposure,
                 "per-frame exposure/gain change, up to +-D (0.12: +-12 %)");
  app.add_option("--white-balance-drift", white_balance,
                 "per-frame, per-channel gain change, up to +-D");
  app.add_option("--vignetting", vignetting, "brightness falls by V at the corners");
  std::optional<double> motion_blur, k3, p1, p2, shot_noise;
  app.add_option("--motion-blur", motion_blur,
                 "shutter open time as a fraction of the frame interval: motion blur along the "
                 "camera path (0: none)");
  app.add_option("--k3", k3, "third D->U radial term, rendered only (the model has k1, k2)");
  app.add_option("--p1", p1, "tangential distortion p1, rendered only");
  app.add_option("--p2", p2, "tangential distortion p2, rendered only");
  app.add_option("--shot-noise", shot_noise,
                 "Poisson shot noise: electrons per grey level (variance L / G at level L; 0: "
                 "none); --noise is the read noise beside it");
  std::optional<bool> bayer;
  app.add_option("--bayer", bayer,
                 "colour filter array: noise on the B G / G R photosites, then demosaiced (true "
                 "or false; colour frames only)");
  // What a real scene has beyond textured planes (not part of the presets).
  app.add_option("--moving-object", options.moving_object,
                 "a textured disc crossing the view at this many image widths per frame (0: none)")
      ->capture_default_str();
  app.add_option("--curved", options.curved_surfaces, "textured cylinders and spheres (0: none)")
      ->capture_default_str();
  app.add_option("--untextured", options.untextured,
                 "share of the scene's patches rendered in one flat colour (0: none)")
      ->capture_default_str();
  if (const auto status = ParseCommandLine(app, args)) return *status;

  options.color = !gray;
  options.hand_path = !line_path;
  options.effects = CameraEffects::Preset(camera);
  CameraEffects& effects = options.effects;
  effects.rolling_shutter_readout = readout.value_or(effects.rolling_shutter_readout);
  effects.exposure_drift = exposure.value_or(effects.exposure_drift);
  effects.white_balance_drift = white_balance.value_or(effects.white_balance_drift);
  effects.vignetting = vignetting.value_or(effects.vignetting);
  effects.exposure_time = motion_blur.value_or(effects.exposure_time);
  effects.k3 = k3.value_or(effects.k3);
  effects.p1 = p1.value_or(effects.p1);
  effects.p2 = p2.value_or(effects.p2);
  effects.shot_noise_gain = shot_noise.value_or(effects.shot_noise_gain);
  effects.bayer = bayer.value_or(effects.bayer);
  options.jpeg_quality = jpeg.value_or(CameraEffects::PresetJpegQuality(camera));

  SynthBurst burst;
  try {
    burst = SynthesizeBurst(options);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  WriteSynthBurst(out, burst);
  std::printf("synth       %s: %d frames %dx%d, f = %.1f px, k1 = %.4f, k2 = %.4f\n", out.c_str(),
              options.frames, options.width, options.height, burst.truth.camera.f, options.k1,
              options.k2);
  return 0;
}

}  // namespace dfsm::tools
