// Frames interpolated on a grid twice as fine before the sweep samples them.
//
// The sweep reads every other frame at sub-pixel positions. Bilinear
// interpolation blurs a sample by an amount that depends on where it falls
// between pixels (none on a pixel, most half-way), while the reference it is
// compared with is read on its pixels, unblurred: the cost is lowest where
// samples fall on pixels, which pulls the winners towards whole pixels of
// parallax. Interpolating the half-pixel nodes once with a cubic
// (Catmull-Rom) and sampling that grid bilinearly halves the distance to a
// node and leaves far less of that blur.
#pragma once

#include <opencv2/core.hpp>

namespace dfsm {

// The (2 cols - 1) x (2 rows - 1) grid whose node (2x, 2y) is pixel (x, y) of
// `image` (CV_32FC1), unchanged, and whose odd nodes are Catmull-Rom
// interpolated half-way between pixels (edges replicated): captured position
// p is grid position 2 p. Reproduces polynomials up to degree 2 exactly.
cv::Mat OversampleTwice(const cv::Mat& image);

}  // namespace dfsm
