// Where the reference frame is weakly textured: there a small aggregation
// window holds too little signal, and the reference's own noise (which every
// frame is compared with, so it does not average out over frames) moves the
// cost minimum. Those pixels aggregate over a wider window.
#pragma once

#include <opencv2/core.hpp>

namespace dfsm {

// CV_8UC1 mask (255/0) of the pixels of `image` (CV_32FC1, grey levels)
// whose whole (2 radius + 1)^2 window has an RMS gradient (central
// differences, grey levels per pixel) below `max_rms_gradient`. Taking the
// whole window keeps the mask off weak texture that borders strong texture,
// where a wide window would let the strong side decide the depth.
cv::Mat WeakTextureMask(const cv::Mat& image, int radius, double max_rms_gradient);

}  // namespace dfsm
