#include "core/dense/depth_discontinuity.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/dense/parallel_rows.h"

namespace dfsm {

void KeepEdgesOfRawWinners(const cv::Mat& raw, const cv::Mat& weight, float max_departure,
                           cv::Mat& refined) {
  CV_Assert(raw.type() == CV_32FC1 && weight.type() == CV_32FC1 && refined.type() == CV_32FC1);
  CV_Assert(raw.size() == weight.size() && raw.size() == refined.size());
  cv::Mat input(raw.size(), CV_32FC1);
  ParallelRows(raw.rows, [&](int y) {
    const float* r = raw.ptr<float>(y);
    const float* w = weight.ptr<float>(y);
    const float* q = refined.ptr<float>(y);
    float* in = input.ptr<float>(y);
    for (int x = 0; x < raw.cols; ++x) in[x] = w[x] > 0.0f ? r[x] : q[x];
  });
  cv::Mat median;
  cv::medianBlur(input, median, 5);
  ParallelRows(raw.rows, [&](int y) {
    const float* m = median.ptr<float>(y);
    float* q = refined.ptr<float>(y);
    for (int x = 0; x < raw.cols; ++x)
      if (std::abs(q[x] - m[x]) > max_departure) q[x] = m[x];
  });
}

void InvalidateAlongDiscontinuities(const cv::Mat& plane, int radius, float max_span,
                                    float min_relative_span, float zero_plane, cv::Mat& weight) {
  CV_Assert(plane.type() == CV_32FC1 && weight.type() == CV_32FC1 && plane.size() == weight.size());
  if (radius <= 0) return;
  // Invalid pixels must not widen the span: they enter the maximum as -inf
  // and the minimum as +inf.
  cv::Mat high(plane.size(), CV_32FC1), low(plane.size(), CV_32FC1);
  ParallelRows(plane.rows, [&](int y) {
    const float* p = plane.ptr<float>(y);
    const float* w = weight.ptr<float>(y);
    float* h = high.ptr<float>(y);
    float* l = low.ptr<float>(y);
    for (int x = 0; x < plane.cols; ++x) {
      const bool valid = w[x] > 0.0f;
      h[x] = valid ? p[x] : -HUGE_VALF;
      l[x] = valid ? p[x] : HUGE_VALF;
    }
  });
  const cv::Mat square =
      cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * radius + 1, 2 * radius + 1));
  cv::dilate(high, high, square);
  cv::erode(low, low, square);
  ParallelRows(plane.rows, [&](int y) {
    const float* h = high.ptr<float>(y);
    const float* l = low.ptr<float>(y);
    float* w = weight.ptr<float>(y);
    for (int x = 0; x < plane.cols; ++x) {
      const float span = h[x] - l[x];
      if (w[x] > 0.0f && span > max_span && span > min_relative_span * (h[x] - zero_plane))
        w[x] = 0.0f;
    }
  });
}

}  // namespace dfsm
