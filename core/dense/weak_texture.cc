#include "core/dense/weak_texture.h"

#include <opencv2/imgproc.hpp>

#include "core/parallel/parallel_for.h"

namespace dfsm {

cv::Mat WeakTextureMask(const cv::Mat& image, int radius, double max_rms_gradient) {
  CV_Assert(image.type() == CV_32FC1 && radius >= 0 && max_rms_gradient >= 0.0);
  const float max_energy = static_cast<float>(max_rms_gradient * max_rms_gradient);
  // In bands of rows (core/parallel/parallel_for.h): OpenCV runs each filter on
  // one core, and over a whole 1080p frame the three full-size temporaries
  // cost ~60 ms. The halo is the window's radius and the central
  // difference's row.
  constexpr int kBandRows = 64;
  cv::Mat mask(image.size(), CV_8UC1);
  ForEachRowBand(image.rows, kBandRows, radius + 1, [&](const RowBand& band) {
    cv::Mat gx, gy;
    const cv::Mat rows = image.rowRange(band.from, band.to);
    // ksize 1 with scale 0.5: the central difference (I(x+1) - I(x-1)) / 2.
    cv::Sobel(rows, gx, CV_32F, 1, 0, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
    cv::Sobel(rows, gy, CV_32F, 0, 1, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
    cv::Mat energy = gx.mul(gx) + gy.mul(gy);
    cv::boxFilter(energy, energy, -1, cv::Size(2 * radius + 1, 2 * radius + 1), cv::Point(-1, -1),
                  true, cv::BORDER_REPLICATE);
    cv::Mat kept = mask.rowRange(band.first, band.last);
    cv::compare(energy.rowRange(band.Own()), max_energy, kept, cv::CMP_LT);
  });
  return mask;
}

}  // namespace dfsm
