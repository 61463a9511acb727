#include "core/dense/depth_discontinuity.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/parallel/parallel_for.h"

namespace dfsm {

namespace {

// Highest and lowest valid (weight > 0) plane index within `radius` of each
// pixel; invalid pixels enter the maximum as -inf and the minimum as +inf,
// so they never widen the span.
void LocalExtremes(const cv::Mat& plane, const cv::Mat& weight, int radius, cv::Mat* high,
                   cv::Mat* low) {
  high->create(plane.size(), CV_32FC1);
  low->create(plane.size(), CV_32FC1);
  ParallelRows(plane.rows, [&](int y) {
    const float* p = plane.ptr<float>(y);
    const float* w = weight.ptr<float>(y);
    float* h = high->ptr<float>(y);
    float* l = low->ptr<float>(y);
    for (int x = 0; x < plane.cols; ++x) {
      const bool valid = w[x] > 0.0f;
      h[x] = valid ? p[x] : -HUGE_VALF;
      l[x] = valid ? p[x] : HUGE_VALF;
    }
  });
  const cv::Mat square =
      cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * radius + 1, 2 * radius + 1));
  cv::dilate(*high, *high, square);
  cv::erode(*low, *low, square);
}

}  // namespace

void KeepEdgesOfRawWinners(const cv::Mat& raw, const cv::Mat& weight, float max_departure,
                           int edge_radius, const SpanBound& edge, cv::Mat& refined) {
  CV_Assert(raw.type() == CV_32FC1 && weight.type() == CV_32FC1 && refined.type() == CV_32FC1);
  CV_Assert(raw.size() == weight.size() && raw.size() == refined.size() && edge_radius >= 0);
  cv::Mat input(raw.size(), CV_32FC1);
  ParallelRows(raw.rows, [&](int y) {
    const float* r = raw.ptr<float>(y);
    const float* w = weight.ptr<float>(y);
    const float* q = refined.ptr<float>(y);
    float* in = input.ptr<float>(y);
    for (int x = 0; x < raw.cols; ++x) in[x] = w[x] > 0.0f ? r[x] : q[x];
  });
  // The 5x5 median in bands of rows: OpenCV runs it on one core (17 ms at
  // 1080p, 11 in bands on two); a median is a selection, so the bands give
  // the whole frame's values exactly.
  constexpr int kBandRows = 64;
  cv::Mat median(input.size(), CV_32FC1);
  ForEachRowBand(input.rows, kBandRows, 2, [&](const RowBand& band) {
    cv::Mat rows;
    cv::medianBlur(input.rowRange(band.from, band.to), rows, 5);
    rows.rowRange(band.Own()).copyTo(median.rowRange(band.first, band.last));
  });
  cv::Mat high, low;
  if (edge_radius > 0) LocalExtremes(median, weight, edge_radius, &high, &low);
  ParallelRows(raw.rows, [&](int y) {
    const float* m = median.ptr<float>(y);
    const float* h = edge_radius > 0 ? high.ptr<float>(y) : nullptr;
    const float* l = edge_radius > 0 ? low.ptr<float>(y) : nullptr;
    float* q = refined.ptr<float>(y);
    for (int x = 0; x < raw.cols; ++x)
      if (std::abs(q[x] - m[x]) > max_departure || (h && edge.ExceededBy(h[x], l[x]))) q[x] = m[x];
  });
}

void InvalidateAlongDiscontinuities(const cv::Mat& plane, int radius, const SpanBound& bound,
                                    cv::Mat& weight) {
  CV_Assert(plane.type() == CV_32FC1 && weight.type() == CV_32FC1 && plane.size() == weight.size());
  if (radius <= 0) return;
  cv::Mat high, low;
  LocalExtremes(plane, weight, radius, &high, &low);
  ParallelRows(plane.rows, [&](int y) {
    const float* h = high.ptr<float>(y);
    const float* l = low.ptr<float>(y);
    float* w = weight.ptr<float>(y);
    for (int x = 0; x < plane.cols; ++x)
      if (w[x] > 0.0f && bound.ExceededBy(h[x], l[x])) w[x] = 0.0f;
  });
}

}  // namespace dfsm
