#include "core/dense/high_pass.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

namespace dfsm {

double HighPassSigma(double sigma_px, int width, int height) {
  if (sigma_px < 0.0) return 0.0;
  if (sigma_px > 0.0) return sigma_px;
  // Measured on TUM at 640x480 (docs/experiments/218-high-passed-frames.md):
  // 1/80 of the side beat 1/40 and 1/20 (wider blurs leave more of the
  // brightness change in).
  return std::max(width, height) / 80.0;
}

cv::Mat HighPass(const cv::Mat& gray, double sigma) {
  CV_Assert(gray.type() == CV_8UC1 && sigma > 0.0);
  // The blur is taken at 1/step of the resolution and brought back
  // bilinearly: it is smooth at the scale of the sigma, and a full-resolution
  // Gaussian of sigma 24 (1080p) cost ~70 ms per frame (193 taps per pass).
  const int step = std::max(1, static_cast<int>(sigma / 4.0));
  cv::Mat image, small, blur;
  gray.convertTo(image, CV_32F);
  if (step > 1) {
    cv::resize(image, small,
               cv::Size((image.cols + step - 1) / step, (image.rows + step - 1) / step), 0, 0,
               cv::INTER_AREA);
    cv::GaussianBlur(small, small, cv::Size(), sigma / step, sigma / step);
    cv::resize(small, blur, image.size(), 0, 0, cv::INTER_LINEAR);
  } else {
    cv::GaussianBlur(image, blur, cv::Size(), sigma, sigma);
  }
  cv::subtract(image, blur, image);
  cv::Mat high;
  image.convertTo(high, CV_8U, 1.0, 128.0);
  return high;
}

}  // namespace dfsm
