#include "core/sparse/blur_matching.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace dfsm {

void BlurMatchingOptions::Check() const {
  if (enabled && exposure_fractions.empty())
    throw std::invalid_argument("blur matching needs at least one exposure fraction");
  for (const double fraction : exposure_fractions)
    if (!(fraction > 0.0 && fraction <= 1.0))
      throw std::invalid_argument("exposure fractions must be in (0, 1], got " +
                                  std::to_string(fraction));
  if (!(min_blur_difference_px > 0.0))
    throw std::invalid_argument("min_blur_difference_px must be > 0");
}

cv::Mat MotionBlurKernel(cv::Point2d velocity, double exposure_fraction) {
  const cv::Point2d segment = exposure_fraction * velocity;
  const double length = std::hypot(segment.x, segment.y);
  if (length < 0.1) return cv::Mat::ones(1, 1, CV_32F);
  const int half = static_cast<int>(std::ceil(length / 2.0)) + 1;
  cv::Mat kernel = cv::Mat::zeros(2 * half + 1, 2 * half + 1, CV_32F);
  // Samples a quarter pixel apart along the segment, each splatted onto its
  // four pixels: the open shutter's time spread evenly along the motion.
  const int samples = std::max(2, static_cast<int>(std::ceil(4.0 * length)) + 1);
  for (int s = 0; s < samples; ++s) {
    const double t = static_cast<double>(s) / (samples - 1) - 0.5;
    const double x = half + t * segment.x, y = half + t * segment.y;
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const float ax = static_cast<float>(x - x0), ay = static_cast<float>(y - y0);
    kernel.at<float>(y0, x0) += (1.0f - ax) * (1.0f - ay);
    kernel.at<float>(y0, x0 + 1) += ax * (1.0f - ay);
    kernel.at<float>(y0 + 1, x0) += (1.0f - ax) * ay;
    kernel.at<float>(y0 + 1, x0 + 1) += ax * ay;
  }
  return kernel / cv::sum(kernel)[0];
}

double BlurDifference(cv::Point2d velocity_a, cv::Point2d velocity_b) {
  const cv::Point2d minus = velocity_a - velocity_b, plus = velocity_a + velocity_b;
  return std::min(std::hypot(minus.x, minus.y), std::hypot(plus.x, plus.y));
}

std::vector<std::optional<cv::Point2d>> FrameVelocities(
    const std::vector<std::optional<cv::Matx33d>>& motion, cv::Point2f point) {
  const int n = static_cast<int>(motion.size());
  std::vector<std::optional<cv::Point2d>> where(n);
  for (int i = 0; i < n; ++i) {
    if (!motion[i]) continue;
    const cv::Vec3d p = *motion[i] * cv::Vec3d(point.x, point.y, 1.0);
    if (std::abs(p[2]) > 1e-12) where[i] = cv::Point2d(p[0] / p[2], p[1] / p[2]);
  }
  std::vector<std::optional<cv::Point2d>> velocity(n);
  for (int i = 0; i < n; ++i) {
    const int before = std::max(0, i - 1), after = std::min(n - 1, i + 1);
    if (after == before || !where[before] || !where[after]) continue;
    velocity[i] = (*where[after] - *where[before]) / static_cast<double>(after - before);
  }
  return velocity;
}

}  // namespace dfsm
