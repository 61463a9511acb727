// Edge-aware global smoothing: the fast global smoother of Min et al., "Fast
// Global Image Smoothing Based on Weighted Least Squares" (IEEE TIP 2014).
// The 2-D weighted least-squares problem
//   min_u sum_p (u_p - f_p)^2 + lambda sum_{p~q} w_pq (u_p - u_q)^2,
//   w_pq = exp(-|g_p - g_q| / sigma)  (g: the guide),
// is approximated by alternating 1-D solves along the rows and the columns,
// each a tridiagonal system, with lambda spread over the iterations. Where the
// guide has an edge the weight vanishes, so a value spreads across a region of
// even brightness and stops at its outline.
//
// Because the smoother is linear in f for a fixed guide, smoothing value x
// confidence and confidence with it and dividing fills the holes of a sparse
// map along the image's regions (normalized convolution): depth_completion.h.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

struct GlobalSmootherOptions {
  // Smoothness: how far a value spreads through a region of even brightness
  // (a 1-D pass spreads over about sqrt(lambda) pixels).
  double lambda = 3000.0;
  // Guide differences (grey levels, 0-255) at which a neighbour's pull falls
  // to 1/e, for a single-channel guide: small, so that the faint outline of a
  // textureless surface stops the spread.
  double sigma = 2.0;
  // The same for a three-channel (colour) guide, on the largest difference of
  // its channels: an edge between two colours of one brightness (an orange
  // wall behind a grey photo) stops the spread there too. Wider than sigma
  // because the largest of three channels' noise exceeds the grey's
  // (docs/experiments/223-fill-guided-by-colour.md).
  double color_sigma = 3.0;
  // Row-and-column passes. One scores as well as three on TUM and on
  // generated bursts (docs/experiments/221-filling-along-regions.md) but leaves
  // streaks along the last pass; each further pass costs ~20 ms at 1080p.
  int iterations = 3;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

// Smooths every image of `images` (CV_32FC1, the guide's size) in place with
// the weights of `guide` (8-bit or float, one channel or three, in the units
// of options.sigma and color_sigma: grey levels 0-255 for the defaults). The
// images share the guide's weights and the systems' factorization.
void SmoothAlongEdges(const cv::Mat& guide, const std::vector<cv::Mat*>& images,
                      const GlobalSmootherOptions& options = {});

}  // namespace dfsm
