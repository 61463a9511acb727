// The frames the plane sweep compares, less their low frequencies. Real
// cameras change brightness between the frames of a burst in ways one gain per
// frame cannot undo: auto exposure with a tone curve, white balance seen
// through the gray conversion, vignetting under motion. Those changes are
// smooth across the image; texture, which the sweep matches on, is not. On TUM
// fr1/xyz (a real webcam) the windows whose depth was worse than a constant
// (AbsRel 49-62 %) came to 4-6 % with it (docs/experiments/218-high-passed-frames.md).
// The blur is approximate (taken at a lower resolution, see HighPass).
#pragma once

#include <opencv2/core.hpp>

namespace dfsm {

// The Gaussian sigma HighPass uses for a width x height burst: `sigma_px`
// where positive, 1/80 of the longer side where 0 (8 px at 640x480, 24 px at
// 1080p), none (0) where negative.
double HighPassSigma(double sigma_px, int width, int height);

// `gray` (CV_8UC1) less its Gaussian blur of `sigma`, offset to mid-grey and
// rounded back to 8 bits (saturating: texture more than 127 levels from its
// surroundings is clipped).
cv::Mat HighPass(const cv::Mat& gray, double sigma);

}  // namespace dfsm
