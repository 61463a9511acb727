#include "core/dense/high_pass.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

namespace dfsm {

double HighPassSigma(double sigma_px, int width, int height) {
  if (sigma_px < 0.0) return 0.0;
  if (sigma_px > 0.0) return sigma_px;
  // Measured on TUM at 640x480 (docs/dense.md): 1/80 of the side beat 1/40
  // and 1/20 (wider blurs leave more of the brightness change in).
  return std::max(width, height) / 80.0;
}

cv::Mat HighPass(const cv::Mat& gray, double sigma) {
  CV_Assert(gray.type() == CV_8UC1 && sigma > 0.0);
  cv::Mat image, blur;
  gray.convertTo(image, CV_32F);
  cv::GaussianBlur(image, blur, cv::Size(), sigma, sigma);
  cv::subtract(image, blur, image);
  cv::Mat high;
  image.convertTo(high, CV_8U, 1.0, 128.0);
  return high;
}

}  // namespace dfsm
