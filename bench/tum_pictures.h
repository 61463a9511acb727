// Side-by-side pictures of a TUM window for docs/ (issue 13, item 5): what
// the pipeline made of real frames, beside what the Kinect measured.
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace dfsm {

// One row: the reference frame | dfsm's depth times `scale` (the global scale
// of the evaluation) | the Kinect depth | the relative error |s d - d*| / d*
// (black: below 1 %, white: 25 % or more). Both depths share one inverse-depth
// colour range, taken from the Kinect's 2nd-98th percentile, in the turbo map
// (near red, far blue); black where there is no depth. Each panel is half
// size; the first titled `title`, the depth `score`, the Kinect's `baseline`.
cv::Mat TumComparisonRow(const cv::Mat& reference_color, const cv::Mat& depth, double scale,
                         const cv::Mat& truth, const std::string& title, const std::string& score,
                         const std::string& baseline);

}  // namespace dfsm
