#include "core/pipeline/photometric_compensation.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace dfsm {

void PhotometricCompensationOptions::Check() const {
  if (!(min_gain_change >= 0.0))
    throw std::invalid_argument("photometric min_gain_change must be >= 0");
  if (!(central_fraction > 0.0 && central_fraction <= 1.0))
    throw std::invalid_argument("photometric central_fraction must be in (0, 1]");
}
namespace {

// A frame reduced to its brightness at a scale the burst's motion cannot
// reach: a few pixels of motion move content by a fraction of a cell.
cv::Mat Brightness(const cv::Mat& gray, int cell) {
  cv::Mat small;
  cv::resize(gray, small, cv::Size(std::max(1, gray.cols / cell), std::max(1, gray.rows / cell)), 0,
             0, cv::INTER_AREA);
  cv::Mat blurred;
  cv::GaussianBlur(small, blurred, cv::Size(), 1.5);
  cv::Mat as_float;
  blurred.convertTo(as_float, CV_32F);
  return as_float;
}

}  // namespace

std::vector<FrameCompensation> CompensateExposure(std::vector<cv::Mat>* gray, int reference,
                                                  const PhotometricCompensationOptions& options) {
  std::vector<FrameCompensation> result(gray->size());
  if (!options.enabled || gray->empty()) return result;
  // Cells of 1/40 of the longer side: 48 px at 1080p, 16 px at VGA.
  const cv::Mat& ref = (*gray)[reference];
  const int cell = std::max(4, std::max(ref.cols, ref.rows) / 40);
  const cv::Mat ref_brightness = Brightness(ref, cell);
  const int margin_x = static_cast<int>(ref_brightness.cols * (1.0 - options.central_fraction) / 2);
  const int margin_y = static_cast<int>(ref_brightness.rows * (1.0 - options.central_fraction) / 2);
  std::vector<float> ratios;
  for (size_t i = 0; i < gray->size(); ++i) {
    if (static_cast<int>(i) == reference) continue;
    const cv::Mat brightness = Brightness((*gray)[i], cell);
    // Exposure and gain scale the signal: the median of the cell-wise ratios,
    // over cells bright enough to measure and away from the border.
    ratios.clear();
    for (int y = margin_y; y < brightness.rows - margin_y; ++y)
      for (int x = margin_x; x < brightness.cols - margin_x; ++x) {
        const float a = ref_brightness.at<float>(y, x), b = brightness.at<float>(y, x);
        if (a > 16.0f && b > 16.0f && a < 240.0f && b < 240.0f) ratios.push_back(a / b);
      }
    if (ratios.size() < 16) continue;
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    FrameCompensation& c = result[i];
    c.gain = ratios[ratios.size() / 2];
    if (std::abs(c.gain - 1.0) < options.min_gain_change) continue;
    cv::Mat compensated;
    (*gray)[i].convertTo(compensated, CV_8U, c.gain, 0.0);  // rounds and saturates
    (*gray)[i] = compensated;
    c.applied = true;
  }
  return result;
}

}  // namespace dfsm
