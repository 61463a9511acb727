// The guided filter of He, Sun and Tang (ECCV 2010 / TPAMI 2013) with a gray
// guide, and its confidence-weighted form for sparse, uneven-quality inputs:
// edge-aware refinement of the depth map guided by the reference image.
#pragma once

#include <opencv2/core.hpp>

namespace dfsm {

// q = a I + b with (a, b) fitted in every (2r+1)^2 window: follows the edges of
// `guide` (CV_32FC1) while smoothing `input` (CV_32FC1). O(1) in r.
cv::Mat GuidedFilter(const cv::Mat& guide, const cv::Mat& input, int radius, float eps);

// GuidedFilter(input * weight) / GuidedFilter(weight): pixels weigh by their
// confidence and weight-0 pixels do not pull their neighbours. `support`
// (optional) receives GuidedFilter(weight); where it is <= 1e-3 the result is 0.
// subsample > 1 fits the linear models on images that much smaller (radius
// scaled alike) and applies them to the full-resolution guide: the fast
// guided filter (He and Sun, 2015), ~subsample^2 cheaper.
cv::Mat WeightedGuidedFilter(const cv::Mat& guide, const cv::Mat& input, const cv::Mat& weight,
                             int radius, float eps, cv::Mat* support = nullptr, int subsample = 1);

}  // namespace dfsm
