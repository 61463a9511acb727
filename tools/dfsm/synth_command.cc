// dfsm synth --out DIR: renders a small-motion burst with ground truth.
#include <cstdio>
#include <stdexcept>

#include "core/synth/burst_synthesizer.h"
#include "tools/dfsm/arg_parser.h"
#include "tools/dfsm/command.h"

namespace dfsm::tools {
namespace {

constexpr const char* kHelp =
    "usage: dfsm synth --out DIR [options]\n"
    "\n"
    "Renders a handheld small-motion burst of a textured 3-D scene (photo-textured\n"
    "slanted planes in front of a background) through the ha2016-d2u camera model,\n"
    "and writes it as dfsm-burst/1 with ground_truth.json and depth_gt.tiff.\n"
    "\n"
    "  --width W --height H  frame size (default 1920x1080)\n"
    "  --frames N            frames (default 10)\n"
    "  --f F                 focal length in pixels (default 1.1 * max(W, H))\n"
    "  --k1 K1 --k2 K2       D->U radial distortion (default -0.06, 0.015)\n"
    "  --baseline M          extent of the camera path in metres (default 0.008)\n"
    "  --rotation DEG        largest rotation against the reference (default 0.5)\n"
    "  --noise SIGMA         sensor noise in grey levels (default 1.0)\n"
    "  --jpeg Q              JPEG round trip at quality Q (default: none)\n"
    "  --supersampling S     S x S samples per pixel (default 3)\n"
    "  --gray                gray8 frames instead of bgr8\n"
    "  --seed N              scene and motion seed (default 1)\n"
    "  --textures DIR        photographs to texture the scene with\n"
    "                        (default /usr/share/doc/opencv-doc/examples/data)\n"
    "\n"
    "What a real camera adds (core/synth/camera_effects.h), each switchable:\n"
    "  --camera ideal|webcam|phone\n"
    "                        preset of the effects below (default ideal: none; phone:\n"
    "                        readout 0.6, exposure 0.12, white balance 0.03, vignetting 0.3)\n"
    "  --rolling-shutter R   readout time as a fraction of the frame interval (0: global)\n"
    "  --exposure-drift D    per-frame exposure/gain change, up to +-D (0.12: +-12 %)\n"
    "  --white-balance-drift D  per-frame, per-channel gain change, up to +-D\n"
    "  --vignetting V        brightness falls by V at the corners\n";

}  // namespace

int RunSynthCommand(const Args& args) {
  ArgParser parser({"out", "width", "height", "frames", "f", "k1", "k2", "baseline", "rotation",
                    "noise", "jpeg", "supersampling", "seed", "textures", "camera",
                    "rolling-shutter", "exposure-drift", "white-balance-drift", "vignetting"},
                   {"gray", "help"});
  parser.Parse(args);
  if (parser.Has("help")) {
    std::fputs(kHelp, stdout);
    return 0;
  }
  if (!parser.Has("out")) throw UsageError("--out DIR is required");
  if (!parser.positionals().empty()) throw UsageError("unexpected argument");
  SynthOptions options;
  options.width = parser.Int("width", options.width);
  options.height = parser.Int("height", options.height);
  options.frames = parser.Int("frames", options.frames);
  options.f = parser.Double("f", options.f);
  options.k1 = parser.Double("k1", options.k1);
  options.k2 = parser.Double("k2", options.k2);
  options.baseline = parser.Double("baseline", options.baseline);
  options.rotation_deg = parser.Double("rotation", options.rotation_deg);
  options.noise_sigma = parser.Double("noise", options.noise_sigma);
  options.jpeg_quality = parser.Int("jpeg", options.jpeg_quality);
  options.supersampling = parser.Int("supersampling", options.supersampling);
  options.seed = static_cast<uint64_t>(parser.Int("seed", 1));
  options.color = !parser.Has("gray");
  options.texture_dir = parser.String("textures", options.texture_dir);
  try {
    options.effects = CameraEffects::Preset(parser.String("camera", "ideal"));
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--camera: ") + e.what());
  }
  CameraEffects& effects = options.effects;
  effects.rolling_shutter_readout =
      parser.Double("rolling-shutter", effects.rolling_shutter_readout);
  effects.exposure_drift = parser.Double("exposure-drift", effects.exposure_drift);
  effects.white_balance_drift = parser.Double("white-balance-drift", effects.white_balance_drift);
  effects.vignetting = parser.Double("vignetting", effects.vignetting);

  SynthBurst burst;
  try {
    burst = SynthesizeBurst(options);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  const std::string out = parser.String("out", "");
  WriteSynthBurst(out, burst);
  std::printf("synth       %s: %d frames %dx%d, f = %.1f px, k1 = %.4f, k2 = %.4f\n", out.c_str(),
              options.frames, options.width, options.height, burst.truth.camera.f, options.k1,
              options.k2);
  return 0;
}

}  // namespace dfsm::tools
