// How sharp each frame of a burst is: motion blur (a hand's faster turn
// within the exposure) and defocus take an image's fine gradients first. A
// blurred frame still tracks where its corners stay distinct; its
// photo-consistency in the dense stage compares a smeared image with a sharp
// one. Reported, not acted on: leaving the blurred frames out of the dense
// stage made TUM fr1/rpy's depth worse (docs/experiments/143-frame-sharpness.md).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

// Per frame (8-bit gray, one size, on one brightness): its mean squared
// gradient (3x3 Sobel) over the sharpest frame's, 1 for that frame. Frames
// are measured at an integer fraction of their size, at most 480 px on the
// shorter side (a third at 1080p: 3 ms a frame on one core of a slow x86-64,
// against 48 ms at full size in float), where a blur that matters still
// spans pixels.
std::vector<double> RelativeSharpness(const std::vector<cv::Mat>& gray);

}  // namespace dfsm
