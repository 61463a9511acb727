// Depth without holes (issue: real footage): the plane sweep leaves pixels
// without a trustworthy minimum (textureless walls, the black monitor of TUM
// fr1, occlusions) and a user of a depth map wants every pixel. The holes get
// the inverse depth of their measured surroundings:
//  1. the edge-aware weighted least-squares spread of the measurements
//     (global_smoother.h, normalized: smoothed value x weight over smoothed
//     weight), guided by the reference in colour where it has colour: a hole
//     in a region of even colour takes the depth of that region's measured
//     outline; TUM's black monitor takes the depth of its bezel, not of the
//     wall around it;
//  2. a hole no measurement reaches that way (a region whose outline has none)
//     falls back to push-pull: a confidence-weighted image pyramid (2x2 sums of
//     value x weight and of weight) carries every measurement up until no
//     level has a hole; going down, a pixel keeps its own weighted mean where
//     its weight is whole and blends in the coarser level where it is not
//     (Gortler et al., "The Lumigraph", 1996); one confidence-weighted guided
//     filter pass (guided_filter.h), guided by the reference image, bends that
//     fill along the image's edges. These holes are a few tenths of a percent
//     of the pixels, so the finest level and the guided pass are evaluated
//     only in tiles around them.
// Measured pixels keep their values: the fill only writes the holes, and the
// confidence map (unchanged) tells measured from filled.
#pragma once

#include <opencv2/core.hpp>

#include "core/dense/global_smoother.h"

namespace dfsm {

struct DepthCompletionOptions {
  // The fallback's guided pass (pixels of the guide); 0: push-pull only.
  int guided_radius = 8;
  // The fallback is evaluated in tiles of this side (even) around the holes
  // it fills, each read with the guided pass's reach around it, instead of
  // over the whole image: the same result to float rounding (a few 1e-6
  // relative) for a fraction of the time. 0: the whole image at once.
  int fallback_tile = 64;
  float guided_eps = 1e-3f;  // on the grey reference scaled to [0, 1]
  // Weight of a filled pixel in the guided pass, relative to a measured one
  // of confidence 1: small, so the measurements steer and the fill follows.
  float filled_weight = 0.05f;
  // The edge-aware spread (step 1); lambda 0: the fallback everywhere.
  GlobalSmootherOptions smoother;
  // A measured pixel weighs in with its confidence to this power. Above 1 the
  // confident interior of a surface outweighs its fringe: the pixels that
  // border a hole carry the lowest confidence there and, at a depth edge,
  // often the nearer surface's depth (the window reaches across the edge).
  // Measured in docs/experiments/223-fill-guided-by-colour.md.
  double confidence_power = 2.0;
  // The spread reads the guide after a median of this size (odd; 0 or 1:
  // none): a webcam's noisy, blocky chroma (4:2:0, JPEG) otherwise stops it
  // inside a surface, and a median, unlike a blur, leaves an edge a step
  // instead of a ramp the spread crosses
  // (docs/experiments/225-median-of-fill-guide.md).
  int guide_median = 3;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

// `values` (CV_32FC1) with every pixel of zero `weight` (CV_32FC1, >= 0; the
// confidence) filled from its measured surroundings; pixels of positive
// weight are returned unchanged. `guide` (same size) is the reference image,
// CV_8UC1 (grey) or CV_8UC3 (BGR). All-zero weight: returns an empty Mat
// (nothing to fill from).
cv::Mat FillHoles(const cv::Mat& values, const cv::Mat& weight, const cv::Mat& guide,
                  const DepthCompletionOptions& options = {});

}  // namespace dfsm
