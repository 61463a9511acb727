// Bursts from the ground-truth generator for the benchmarks: rendering a
// 1080p burst takes seconds, so each size is rendered once and kept for every
// run in the process.
#pragma once

#include <map>
#include <memory>
#include <tuple>

#include "core/synth/burst_synthesizer.h"

namespace dfsm {

struct RenderedBurst {
  Burst burst;        // as ReadBurst would return it
  GroundTruth truth;  // camera, poses, reference depth
};

// The default generator's burst of this size (seed 1, no JPEG).
inline const RenderedBurst& Rendered(int width, int height, int frames) {
  static std::map<std::tuple<int, int, int>, std::unique_ptr<RenderedBurst>> cache;
  std::unique_ptr<RenderedBurst>& rendered = cache[{width, height, frames}];
  if (!rendered) {
    SynthOptions options;
    options.width = width;
    options.height = height;
    options.frames = frames;
    const SynthBurst synth = SynthesizeBurst(options);
    rendered = std::make_unique<RenderedBurst>(RenderedBurst{ToBurst(synth), synth.truth});
  }
  return *rendered;
}

}  // namespace dfsm
