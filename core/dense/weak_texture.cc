#include "core/dense/weak_texture.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

namespace dfsm {

cv::Mat WeakTextureMask(const cv::Mat& image, int radius, double max_rms_gradient) {
  CV_Assert(image.type() == CV_32FC1 && radius >= 0 && max_rms_gradient >= 0.0);
  const float max_energy = static_cast<float>(max_rms_gradient * max_rms_gradient);
  // In bands of rows on the pool: OpenCV runs each filter on one core, and
  // over a whole 1080p frame the three full-size temporaries cost ~60 ms.
  // A band is computed from its rows and `halo` more on each side (the
  // window's radius, and the central difference's row), so that the rows it
  // keeps read only rows of the image, never a border the band made up.
  constexpr int kBandRows = 64;
  const int halo = radius + 1;
  cv::Mat mask(image.size(), CV_8UC1);
  const int bands = (image.rows + kBandRows - 1) / kBandRows;
  cv::parallel_for_(cv::Range(0, bands), [&](const cv::Range& range) {
    cv::Mat gx, gy, energy;
    for (int b = range.start; b < range.end; ++b) {
      const int first = b * kBandRows, last = std::min(image.rows, first + kBandRows);
      const int from = std::max(0, first - halo), to = std::min(image.rows, last + halo);
      const cv::Mat rows = image.rowRange(from, to);
      // ksize 1 with scale 0.5: the central difference (I(x+1) - I(x-1)) / 2.
      cv::Sobel(rows, gx, CV_32F, 1, 0, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
      cv::Sobel(rows, gy, CV_32F, 0, 1, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
      energy = gx.mul(gx) + gy.mul(gy);
      cv::boxFilter(energy, energy, -1, cv::Size(2 * radius + 1, 2 * radius + 1), cv::Point(-1, -1),
                    true, cv::BORDER_REPLICATE);
      cv::Mat kept = mask.rowRange(first, last);
      cv::compare(energy.rowRange(first - from, last - from), max_energy, kept, cv::CMP_LT);
    }
  });
  return mask;
}

}  // namespace dfsm
