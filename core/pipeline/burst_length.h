// dfsmd's "frames": "auto": of the frames a capture took, the burst keeps as
// many as its motion needs for depth. The parallax is result.json's
// parallax.median_px (the tracks' motion with the rotation the adjustment
// found taken out) of the pipeline run without its dense stage: the same
// repeated-frame check, exposure compensation and sparse stage as the run
// that follows. A cheaper measure before reconstruction could not tell a
// phone burst that moved 4 mm from one held still
// (docs/experiments/006-burst-length.md). Lengths are tried fewest first, so a
// burst that moved enough costs one sparse stage more than a fixed one.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/io/progress.h"

namespace dfsm {

// The parallax (median, pixels) below which a burst is too still for depth:
// dfsmd's "frames": "auto" fails a capture that stays below it, and a map
// made from less is unreliable (DepthCheckOptions::min_parallax_px;
// docs/experiments/036-too-still-for-depth.md).
inline constexpr double kTooStillParallaxPx = 0.5;

// Declared only: dfsmd's job processor holds the options without the
// pipeline's headers (Eigen's parameter names clash with <resolv.h>'s
// macros, which the HTTP server brings in first).
struct Burst;            // core/io/burst.h
struct PipelineOptions;  // core/pipeline/pipeline.h

struct BurstLengthOptions {
  // The lengths tried, ascending; those above the burst's frames are left
  // out and the burst's whole length is tried last.
  std::vector<int> lengths = {10, 15, 20};
  // A length is enough once its parallax (the sparse stage's median, in
  // pixels) reaches this ...
  double target_parallax_px = 2.0;
  // ... and the burst too still for depth where even all its frames stay
  // below this.
  double min_parallax_px = kTooStillParallaxPx;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

enum class BurstLengthReason {
  kParallaxReached,  // the fewest frames tried whose parallax reaches the target
  kAllFrames,        // every frame: the target was not reached
  kTooStill,         // every frame, and still below min_parallax_px
};

const char* BurstLengthReasonName(BurstLengthReason reason);

struct BurstLengthTrial {
  int frames = 0;
  double parallax_px = 0.0;  // 0 where the sparse stage failed
  std::string error;         // why it failed, if it did
};

struct BurstLength {
  int frames = 0;
  double parallax_px = 0.0;
  BurstLengthReason reason = BurstLengthReason::kAllFrames;
  std::vector<BurstLengthTrial> trials;
};

// The `frames` frames of `burst` nearest its reference: the first where the
// reference is the first frame, the last where it is the last (a capture's
// reference is the frame nearest its trigger), else those around it.
Burst FramesFromReference(const Burst& burst, int frames);

// The progress lap of the trials (core/io/progress.h): a fraction of the
// lengths tried so far, of at most how many there are.
inline constexpr const char* kBurstLengthLap = "auto_frames";

// How many frames of `burst` (counted as FramesFromReference counts them) its
// parallax needs under `pipeline` (its dense stage is not run); `progress`
// hears kBurstLengthLap after each trial.
BurstLength ChooseBurstLength(const Burst& burst, const PipelineOptions& pipeline,
                              const BurstLengthOptions& options,
                              const ProgressCallback& progress = {});

// result.json's "auto_frames": frames taken of how many, the parallax, the
// target, the reason and every length tried.
nlohmann::json ToJson(const BurstLength& length, int frames_available,
                      const BurstLengthOptions& options);

}  // namespace dfsm
