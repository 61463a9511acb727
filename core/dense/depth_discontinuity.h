// Depth discontinuities of the plane map. The guided refinement smooths
// across a depth edge wherever the reference image does not show it (a
// textured object in front of a dull background), and the pixels along an
// edge are mixed and half-occluded: their winners are unreliable whatever the
// aggregation. On generated 640x480 bursts these few percent of the pixels
// carried about 60 % of the depth error (docs/experiments/201-accuracy-true-geometry.md).
#pragma once

#include <opencv2/core.hpp>

namespace dfsm {

// When the plane indices around a pixel span a break between two surfaces
// rather than noise or relief: more than `max_span` planes and more than
// `min_relative_span` of the larger inverse depth, plane `zero_plane` (<= 0)
// being inverse depth 0. Both bounds: a span of a few tenths of a pixel of
// parallax is noise on a far surface, and a span of many pixels is the relief
// of a near one (a flower head at 30 cm), not a break between surfaces.
struct SpanBound {
  float max_span = 0.0f;
  float min_relative_span = 0.0f;
  float zero_plane = 0.0f;

  bool ExceededBy(float high, float low) const {
    const float span = high - low;
    return span > max_span && span > min_relative_span * (high - zero_plane);
  }
};

// Takes the 5x5 median of the raw winners where `refined` departs from it by
// more than `max_departure` planes (the refinement crossed an edge that the
// median, which keeps straight edges in place, did not), and everywhere
// within `edge_radius` of a break (`edge`) in that median: there the guided
// filter's linear models straddle both surfaces and shift the farther one by
// less than max_departure, which on a far background is still several
// percent of its depth. `raw` and `refined` are CV_32FC1 plane indices;
// pixels whose `weight` is 0 enter the median with their refined value and
// take no part in finding breaks. edge_radius 0: departures only.
void KeepEdgesOfRawWinners(const cv::Mat& raw, const cv::Mat& weight, float max_departure,
                           int edge_radius, const SpanBound& edge, cv::Mat& refined);

// Sets `weight` to 0 at pixels within `radius` of which the valid plane
// indices (weight > 0) span a break (`bound`).
void InvalidateAlongDiscontinuities(const cv::Mat& plane, int radius, const SpanBound& bound,
                                    cv::Mat& weight);

}  // namespace dfsm
