// A calibration's own lens where ha2016-d2u holds it only approximately:
// OpenCV's pinhole with fx != fy allowed and its Undistorted -> Distorted
// distortion, radial, tangential and rational (k1 k2 p1 p2 [k3 [k4 k5 k6]]).
// A known calibration in this model is fitted to ha2016-d2u for the pipeline
// (core/export/calibration_import.h); the frames are then resampled from this
// lens onto the fit's pixel grid (core/pipeline/lens_resampling.h), so that
// what the fit misses does not misplace every pixel of every frame. The
// model's one definition is OpenCV's (cv::projectPoints, cv::undistortPoints),
// where these values are used.
#pragma once

#include <vector>

namespace dfsm {

struct OpenCvLens {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  std::vector<double> distortion;  // empty, or 4, 5 or 8 coefficients
};

}  // namespace dfsm
