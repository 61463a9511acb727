#include "core/dense/weak_texture.h"

#include <opencv2/imgproc.hpp>

namespace dfsm {

cv::Mat WeakTextureMask(const cv::Mat& image, int radius, double max_rms_gradient) {
  CV_Assert(image.type() == CV_32FC1 && radius >= 0 && max_rms_gradient >= 0.0);
  cv::Mat gx, gy;
  // ksize 1 with scale 0.5: the central difference (I(x+1) - I(x-1)) / 2.
  cv::Sobel(image, gx, CV_32F, 1, 0, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
  cv::Sobel(image, gy, CV_32F, 0, 1, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
  cv::Mat energy = gx.mul(gx) + gy.mul(gy);
  cv::boxFilter(energy, energy, -1, cv::Size(2 * radius + 1, 2 * radius + 1), cv::Point(-1, -1),
                true, cv::BORDER_REPLICATE);
  return energy < static_cast<float>(max_rms_gradient * max_rms_gradient);
}

}  // namespace dfsm
