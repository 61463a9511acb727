// Per-frame gain and bias compensation: auto exposure and gain change a
// frame's brightness from one frame to the next, which breaks the brightness
// constancy that KLT tracking and the plane sweep's photo-consistency assume
// (docs/experiments/112-camera-effects.md: +-12 % exposure drift left 28-52 %
// of the depth map). Each frame is scaled onto the reference's brightness by
// the median ratio of the two, compared cell by cell at a scale the burst's
// few pixels of motion cannot reach. (Matching means and spreads of the whole
// frame was tried first: content moving in and out of view alone moved them
// by over 1 %, which made an ideal burst worse.)
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

struct PhotometricCompensationOptions {
  // Frames whose gain is within this of 1 are left as they are (bit-exact
  // for a camera without drift).
  double min_gain_change = 0.02;
  // Share of the image, around its centre, that the ratios are taken on:
  // the border holds content that moves in and out of view.
  double central_fraction = 0.8;
  bool enabled = true;

  // Throws std::invalid_argument naming the option out of its range.
  void Check() const;
};

struct FrameCompensation {
  double gain = 1.0;  // I' = gain * I
  bool applied = false;
};

// Compensates every frame but the reference in place (CV_8UC1 frames).
std::vector<FrameCompensation> CompensateExposure(
    std::vector<cv::Mat>* gray, int reference, const PhotometricCompensationOptions& options = {});

}  // namespace dfsm
