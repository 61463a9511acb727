#include "core/pipeline/frame_sharpness.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

namespace dfsm {
namespace {

// Per pixel, at most kMeasuredSide px on the shorter side.
constexpr int kMeasuredSide = 480;

double GradientEnergy(const cv::Mat& gray) {
  const int factor = (std::min(gray.cols, gray.rows) + kMeasuredSide - 1) / kMeasuredSide;
  cv::Mat image = gray, dx, dy;
  if (factor > 1)
    cv::resize(gray, image, cv::Size(gray.cols / factor, gray.rows / factor), 0, 0, cv::INTER_AREA);
  // 16-bit derivatives: a 3x3 Sobel of 8 bits reaches 1020 at most.
  cv::Sobel(image, dx, CV_16S, 1, 0, 3);
  cv::Sobel(image, dy, CV_16S, 0, 1, 3);
  return (cv::norm(dx, cv::NORM_L2SQR) + cv::norm(dy, cv::NORM_L2SQR)) /
         static_cast<double>(image.total());
}

}  // namespace

std::vector<double> RelativeSharpness(const std::vector<cv::Mat>& gray) {
  std::vector<double> energy(gray.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(gray.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) energy[i] = GradientEnergy(gray[i]);
  });
  const double sharpest = energy.empty() ? 0.0 : *std::max_element(energy.begin(), energy.end());
  for (double& e : energy) e = sharpest > 0.0 ? e / sharpest : 1.0;
  return energy;
}

}  // namespace dfsm
