// Depth discontinuities of the plane map. The guided refinement smooths
// across a depth edge wherever the reference image does not show it (a
// textured object in front of a dull background), and the pixels along an
// edge are mixed and half-occluded: their winners are unreliable whatever the
// aggregation. On generated 640x480 bursts these few percent of the pixels
// carried about 60 % of the depth error (docs/dense.md).
#pragma once

#include <opencv2/core.hpp>

namespace dfsm {

// Where `refined` departs by more than `max_departure` planes from the 5x5
// median of the raw winners, the refinement crossed an edge that the median
// (which keeps straight edges in place) did not: takes the median there.
// `raw` and `refined` are CV_32FC1 plane indices; pixels whose `weight` is 0
// enter the median with their refined value.
void KeepEdgesOfRawWinners(const cv::Mat& raw, const cv::Mat& weight, float max_departure,
                           cv::Mat& refined);

// Sets `weight` to 0 at pixels within `radius` of which the valid plane
// indices (weight > 0) span more than `max_span` planes and more than
// `min_relative_span` of the larger inverse depth there, plane `zero_plane`
// (<= 0) being inverse depth 0. Both bounds: a span of a few tenths of a pixel
// of parallax is noise on a far surface, and a span of many pixels is the
// relief of a near one (a flower head at 30 cm), not a break between surfaces.
void InvalidateAlongDiscontinuities(const cv::Mat& plane, int radius, float max_span,
                                    float min_relative_span, float zero_plane, cv::Mat& weight);

}  // namespace dfsm
