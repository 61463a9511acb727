// The ground-truth generator: renders a handheld small-motion burst of a
// textured 3-D scene (slanted, photo-textured planes at several depths in front
// of a background) through the contract's camera model, with its exact poses,
// calibration and reference depth.
#pragma once

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/io/burst.h"
#include "core/io/ground_truth.h"
#include "core/synth/camera_effects.h"

namespace dfsm {

struct SynthOptions {
  int width = 1920;
  int height = 1080;
  int frames = 10;
  double f = 0.0;  // pixels; 0: 1.1 * max(width, height)
  double k1 = -0.06;
  double k2 = 0.015;
  double baseline = 0.008;    // largest distance between two camera centres, metres
  double rotation_deg = 0.5;  // largest rotation of a frame against the reference
  double noise_sigma = 1.0;   // Gaussian sensor noise, grey levels (0: none)
  int jpeg_quality = 0;       // 1..100: JPEG round trip of every frame; 0: none
  int supersampling = 3;      // samples per pixel side (anti-aliasing)
  bool color = true;          // bgr8 frames, else gray8
  CameraEffects effects;      // rolling shutter, exposure, white balance, vignetting (off)
  uint64_t seed = 1;
  // Where real photographs are looked for (Debian's opencv-doc); a procedural
  // texture replaces any that is missing.
  std::string texture_dir = "/usr/share/doc/opencv-doc/examples/data";
};

struct SynthBurst {
  BurstManifest manifest;       // reference 0, timestamps at 30 fps, source {"synthetic": options}
  std::vector<cv::Mat> frames;  // CV_8UC3 (BGR) or CV_8UC1, as captured (distorted)
  GroundTruth truth;            // camera, poses (X_i = R_i X_ref + T_i, metres), reference depth
};

// Deterministic for given options. Throws std::invalid_argument naming a bad option.
SynthBurst SynthesizeBurst(const SynthOptions& options);

// Writes the dfsm-burst/1 directory with ground_truth.json and depth_gt.tiff.
void WriteSynthBurst(const std::filesystem::path& burst_dir, const SynthBurst& burst);

// A Burst in memory as ReadBurst would return it for the written directory.
Burst ToBurst(const SynthBurst& burst);

// A stand-in for the sparse stage's inverse depths where only the dense stage
// is measured: 1 / depth of the truth at the centres of a grid x grid lattice
// over the reference (cells without depth skipped).
std::vector<double> SparseInverseDepthsFromTruth(const GroundTruth& truth, int grid = 20);

}  // namespace dfsm
