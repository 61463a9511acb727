// Semi-global aggregation of a cost volume over the plane index (Hirschmueller,
// "Stereo Processing by Semiglobal Matching and Mutual Information", PAMI
// 2008): each pixel's cost curve is replaced by the sum, over eight
// directions, of the cheapest path costs that reach it, where a path pays a
// small penalty for a step of one plane between neighbours and a large one
// for any larger step. A pixel whose own curve is flat (no texture) or
// ambiguous (repetitive texture) takes the depth its surroundings support; a
// curve with a clear minimum keeps it.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "core/dense/plane_selection.h"

namespace dfsm {

struct SemiGlobalOptions {
  // Penalties in the cost's units (mean truncated grey-level difference, at
  // most the truncation, 10 by default). P1: the price of a step of one plane
  // between neighbours, which slanted surfaces take every few pixels. P2: the
  // price of any larger step (a depth edge), where the guide shows no edge
  // between the two neighbours; across a guide edge of `edge_gradient` grey
  // levels it is halved, and lowered toward P1 across stronger ones, so that
  // depth edges follow image edges. Both far above the cost differences
  // between planes: the coarse level only has to find the right valley, and
  // the full-resolution window (+-3 or +-4 planes) places the depth within it. Swept
  // from 0.1/1 to 16/128 on generated bursts and TUM fr1/xyz
  // (docs/experiments/212-regularized-depth.md): better on both up to 8/64, flat
  // beyond.
  float small_step_penalty = 8.0f;
  float large_step_penalty = 64.0f;
  float edge_gradient = 8.0f;

  // Throws std::invalid_argument naming the first option out of range.
  void Check() const;
};

// The winners of `costs` (slice p: the cost of plane p at every pixel,
// CV_32FC1, all of the guide's size; kNoCost where unseen) after semi-global
// aggregation, selected as SelectPlanes selects them from the eight path costs
// summed (the confidence is that of the aggregated curve; ConfidenceOfPlanes
// gives the pixel's own). A plane that had no cost is never selected, so no
// pixel is given a depth its frames never saw; along a path such a plane
// costs `missing_cost`, the worst a seen plane can cost (the sweep's
// truncation). `guide` (CV_32FC1) is the reference image on the same grid.
// Memory: one more volume (the pixel-major sums, the winners selected from
// it) and a few rows per worker.
PlaneSelection SelectSemiGlobal(const std::vector<cv::Mat>& costs, const cv::Mat& guide,
                                float missing_cost, const SemiGlobalOptions& options);

}  // namespace dfsm
