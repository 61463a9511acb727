// The ground-truth generator: renders a handheld small-motion burst of a
// textured 3-D scene (slanted, photo-textured planes at several depths in front
// of a background; optionally curved surfaces, flat-colour patches and an
// object that moves on its own) through the contract's camera model and the
// camera effects of camera_effects.h, with its exact poses, calibration and
// reference depth.
#pragma once

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/io/burst.h"
#include "core/io/ground_truth.h"
#include "core/synth/camera_effects.h"
#include "core/synth/textured_scene.h"

namespace dfsm {

struct SynthOptions {
  int width = 1920;
  int height = 1080;
  int frames = 10;
  double f = 0.0;  // pixels; 0: 1.1 * max(width, height)
  double k1 = -0.06;
  double k2 = 0.015;
  double baseline = 0.008;    // largest distance between two camera centres, metres
  double rotation_deg = 0.5;  // largest rotation of a frame against the first one
  double noise_sigma = 1.0;   // Gaussian sensor noise, grey levels (0: none)
  int jpeg_quality = 0;       // 1..100: JPEG round trip of every frame; 0: none
  int supersampling = 3;      // samples per pixel side (anti-aliasing)
  bool color = true;          // bgr8 frames, else gray8
  CameraEffects effects;      // rolling shutter, exposure, ..., motion blur, shot noise (off)
  // A hand's physiological tremor on the orientation, degrees per axis at
  // most (CameraPathOptions::oscillation_deg). 0: the smooth wander alone.
  double oscillation_deg = 0.0;
  // Rows and blurred exposures rendered from the hand's own path between
  // frames (CameraPathOptions::BetweenFrames::kHand), which curves and, with
  // the oscillation, bends within a frame, as a held camera's does; false:
  // the line between frame poses, the pipeline's own rolling-shutter model,
  // for tests of that model's mechanics (the line leaves the self-calibration
  // a misfit it cannot see on the line's own rows:
  // docs/experiments/025-the-hands-path-by-default.md).
  bool hand_path = true;
  // Scene content beyond textured planes (issue 13), each off at 0:
  double moving_object = 0.0;  // a textured disc crossing the view, image widths per frame
  int curved_surfaces = 0;     // textured cylinders and spheres among the patches
  double untextured = 0.0;     // share of the patches rendered in one flat colour
  uint64_t seed = 1;
  // The reference frame (the manifest's "reference"): the truth's poses are
  // relative to it and depth_gt is its depth. The frames themselves do not
  // depend on it.
  int reference = 0;
  // Where real photographs are looked for (Debian's opencv-doc); a procedural
  // texture replaces any that is missing.
  std::string texture_dir = "/usr/share/doc/opencv-doc/examples/data";
};

struct SynthBurst {
  BurstManifest manifest;  // options.reference, timestamps at 30 fps, source {"synthetic": options}
  std::vector<cv::Mat> frames;  // CV_8UC3 (BGR) or CV_8UC1, as captured (distorted)
  GroundTruth truth;            // camera, poses (X_i = R_i X_ref + T_i, metres), reference depth
  CameraEffects effects;        // as rendered; k3, p1, p2 go into ground_truth.json
  // With a moving object: per frame, 255 where any sample of a pixel saw it
  // (CV_8UC1), and the bounding box of that mask (empty where it is out of view).
  std::vector<cv::Mat> object_masks;
  std::vector<cv::Rect> object_boxes;
};

// The camera model of the burst `options` renders (f 0: 1.1 x the longer side;
// principal point at the centre); the effects' k3, p1, p2 are not part of it.
CameraModel SynthCamera(const SynthOptions& options);

// Whether the rendered lens (k1, k2 and the effects' k3) maps the distorted
// image to the undistorted one monotonically out to the corner, with a margin;
// SynthesizeBurst refuses a lens that does not.
bool RenderedLensIsInvertible(const SynthOptions& options);

// Deterministic for given options. Throws std::invalid_argument naming a bad option.
SynthBurst SynthesizeBurst(const SynthOptions& options);

// The scene SynthesizeBurst renders for `options` with focal length f.
SceneOptions SceneOptionsFor(const SynthOptions& options, double f);

// Writes the dfsm-burst/1 directory with ground_truth.json and depth_gt.tiff;
// ground_truth.json also gets the rendering's extra lens terms (k3, p1, p2,
// not part of the camera model) and, with a moving object, its per-frame box
// and mask file (object_masks/NNNNNN.png).
void WriteSynthBurst(const std::filesystem::path& burst_dir, const SynthBurst& burst);

// A Burst in memory as ReadBurst would return it for the written directory.
Burst ToBurst(const SynthBurst& burst);

// A stand-in for the sparse stage's inverse depths where only the dense stage
// is measured: 1 / depth of the truth at the centres of a grid x grid lattice
// over the reference (cells without depth skipped).
std::vector<double> SparseInverseDepthsFromTruth(const GroundTruth& truth, int grid = 20);

}  // namespace dfsm
