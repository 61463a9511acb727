// Photo-consistency of the reference against every other frame for
// fronto-parallel planes, aggregated over a square window: the cost volume of
// the plane sweep, either over every plane of the lattice (coarse level) or
// over a narrow per-pixel window of planes (full resolution).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "core/dense/inverse_depth_lattice.h"
#include "core/dense/plane_selection.h"
#include "core/dense/sweep_level.h"

namespace dfsm {

// Cost of pixels where too few frames saw the plane.
inline constexpr float kNoCost = 1.0e9f;

struct PhotoCostOptions {
  // Absolute intensity differences are truncated here (grey levels): an
  // occluded or specular frame costs at most this much.
  float truncation = 10.0f;
  // Half-width of the square aggregation window (box filter), level pixels.
  int window_radius = 2;
  // Shiftable windows: a pixel takes the lowest aggregated cost of the
  // windows whose centres lie within this radius (a min filter after the
  // box), so a pixel near a depth edge can use a window that does not cross
  // it, and the nearer surface's texture no longer spreads into the farther
  // one. 0: the centred window only.
  int shiftable_radius = 0;
  // Weakly textured pixels: where wide_window_mask (CV_8UC1, level size) is
  // set, the cost is aggregated over a window of half-width
  // wide_window_radius instead. 0 or an empty mask: off.
  int wide_window_radius = 0;
  cv::Mat wide_window_mask;
  // Aggregated samples below this share of (frames x window) leave the cost
  // at kNoCost (the plane leaves most frames).
  float min_valid_share = 0.5f;
  // SweepAllPlanes projects every this many planes exactly (and the last)
  // and interpolates the samples of the planes between on the straight line
  // between their two projections (see SweepPlaneWindow for why that holds).
  // The caller picks it so that a segment spans a couple of pixels of parallax.
  int projected_every = 1;
  // SweepPlaneWindow only: the winners are drawn towards a seed (SeedPrior,
  // plane_selection.h; its seed on the level's grid). weight 0: off.
  SeedPrior seed_prior;
};

// The cost volume is streamed: the level is swept in bands of rows (plus
// the aggregation window's halo above and below, clamped into the image,
// which is what a replicated border aggregates), and each band's winners are
// selected before the next band is swept. The volume never exists in full;
// memory is one band of slices per worker (a 1080p window sweep held 14 full
// slices, 116 MB, and the page faults of touching them cost more than a
// fifth of the stage).

// Sweeps every plane of the lattice (coarse level): the per-slice cost is the
// mean truncated absolute difference over frames and window. Returns the
// winner, its confidence and edge flag per pixel (SelectPlanes).
PlaneSelection SweepAllPlanes(const SweepLevel& level, const InverseDepthLattice& lattice,
                              const PhotoCostOptions& options);

// The same sweep, returning the aggregated cost volume itself: slice p is the
// cost of lattice plane p at every level pixel (kNoCost where too few samples
// saw it), for a regularization that needs every pixel's whole curve at once
// (semi_global.h). The coarse level only: 1080p's coarse volume (480 x 270 x
// 39-40 planes) is 21 MB, a 640x480 one at most 320 x 240 x 128 x 4 B = 39 MB.
std::vector<cv::Mat> SweepAllPlaneCosts(const SweepLevel& level, const InverseDepthLattice& lattice,
                                        const PhotoCostOptions& options);

// Sweeps `count` planes per pixel: slice k holds, at each pixel, the cost of
// lattice plane first_plane(pixel) + k * stride (first_plane: CV_32SC1, level
// size, every window inside the lattice). Neighbours in a window are
// aggregated slice by slice, i.e. at their own window's k-th plane: exact
// where first_plane is locally constant, which the caller's smooth coarse
// estimate makes almost everywhere. Returns the winners as SelectPlanes(costs,
// first_plane, stride) would, or, with options.seed_prior, as
// SelectPlanesNearSeedInto does.
PlaneSelection SweepPlaneWindow(const SweepLevel& level, const InverseDepthLattice& lattice,
                                const cv::Mat& first_plane, int count, int stride,
                                const PhotoCostOptions& options);

}  // namespace dfsm
