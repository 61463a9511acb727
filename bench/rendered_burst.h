// Bursts from the ground-truth generator for the benchmarks: rendering a
// 1080p burst takes seconds, so each size is rendered once and kept for every
// run in the process.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <tuple>

#include "core/synth/burst_synthesizer.h"

namespace dfsm {

struct RenderedBurst {
  Burst burst;        // as ReadBurst would return it
  GroundTruth truth;  // camera, poses, reference depth
};

// The default generator's burst of this size (seed 1), through a camera
// preset's effects and JPEG (CameraEffects::Preset: "ideal", no JPEG, by
// default), at the generator's tremor or at rotation_deg (> 0).
inline const RenderedBurst& Rendered(int width, int height, int frames,
                                     const std::string& camera = "ideal",
                                     double rotation_deg = 0.0) {
  static std::map<std::tuple<int, int, int, std::string, double>, std::unique_ptr<RenderedBurst>>
      cache;
  std::unique_ptr<RenderedBurst>& rendered = cache[{width, height, frames, camera, rotation_deg}];
  if (!rendered) {
    SynthOptions options;
    options.width = width;
    options.height = height;
    options.frames = frames;
    options.effects = CameraEffects::Preset(camera);
    options.jpeg_quality = CameraEffects::PresetJpegQuality(camera);
    if (rotation_deg > 0.0) options.rotation_deg = rotation_deg;
    const SynthBurst synth = SynthesizeBurst(options);
    rendered = std::make_unique<RenderedBurst>(RenderedBurst{ToBurst(synth), synth.truth});
  }
  return *rendered;
}

}  // namespace dfsm
