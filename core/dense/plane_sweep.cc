#include "core/dense/plane_sweep.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace dfsm {
namespace {

// Bilinear sample of a frame at (x, y); false outside the image.
inline bool SampleBilinear(const cv::Mat& image, float x, float y, float* value) {
  if (!(x >= 0.0f && y >= 0.0f && x < image.cols - 1 && y < image.rows - 1)) return false;
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float fx = x - x0, fy = y - y0;
  const float* p = image.ptr<float>(y0) + x0;
  const float* q = p + image.step1();
  const float top = p[0] + fx * (p[1] - p[0]);
  const float bottom = q[0] + fx * (q[1] - q[0]);
  *value = top + fy * (bottom - top);
  return true;
}

// Adds, for one row of the reference and one frame, the truncated absolute
// difference at inverse depth w(x) = w0(x) to sum/count. `w` holds one inverse
// depth per pixel of the row.
inline void AccumulateRow(const SweepLevel& level, int frame, int y, const float* w,
                          float truncation, float* sum, float* count) {
  const PlaneHomography& h = level.warps[frame];
  const cv::Mat& image = level.frames[frame];
  const float* rx = level.ray_x.ptr<float>(y);
  const float* ry = level.ray_y.ptr<float>(y);
  const float* ref = level.reference.ptr<float>(y);
  const RadialInverse& radial = *level.radial;
  for (int x = 0; x < level.reference.cols; ++x) {
    const float X = h.r[0] * rx[x] + h.r[1] * ry[x] + h.r[2] + w[x] * h.t[0];
    const float Y = h.r[3] * rx[x] + h.r[4] * ry[x] + h.r[5] + w[x] * h.t[1];
    const float Z = h.r[6] * rx[x] + h.r[7] * ry[x] + h.r[8] + w[x] * h.t[2];
    if (!(Z > 0.0f)) continue;
    const float inv = 1.0f / Z;
    const float x_u = X * inv, y_u = Y * inv;
    const float ratio = radial.Ratio(x_u * x_u + y_u * y_u);
    if (ratio < 0.0f) continue;
    const float scaled = level.focal * ratio;
    float value;
    if (!SampleBilinear(image, level.centre_x + scaled * x_u, level.centre_y + scaled * y_u,
                        &value))
      continue;
    sum[x] += std::min(std::abs(value - ref[x]), truncation);
    count[x] += 1.0f;
  }
}

// Box-aggregates sum and count in place and turns them into the mean cost.
void AggregateSlice(cv::Mat& sum, cv::Mat& count, int frames, const PhotoCostOptions& options) {
  const cv::Size window(2 * options.window_radius + 1, 2 * options.window_radius + 1);
  cv::boxFilter(sum, sum, -1, window, cv::Point(-1, -1), false, cv::BORDER_REPLICATE);
  cv::boxFilter(count, count, -1, window, cv::Point(-1, -1), false, cv::BORDER_REPLICATE);
  const float min_count = options.min_valid_share * frames * window.area();
  for (int y = 0; y < sum.rows; ++y) {
    float* s = sum.ptr<float>(y);
    const float* c = count.ptr<float>(y);
    for (int x = 0; x < sum.cols; ++x) s[x] = c[x] >= min_count ? s[x] / c[x] : kNoCost;
  }
}

}  // namespace

std::vector<cv::Mat> SweepAllPlanes(const SweepLevel& level, const InverseDepthLattice& lattice,
                                    const PhotoCostOptions& options) {
  const int frames = static_cast<int>(level.frames.size());
  const cv::Size size = level.reference.size();
  std::vector<cv::Mat> costs(lattice.planes);
  cv::parallel_for_(cv::Range(0, lattice.planes), [&](const cv::Range& planes) {
    std::vector<float> w(size.width);
    for (int plane = planes.start; plane < planes.end; ++plane) {
      std::fill(w.begin(), w.end(), static_cast<float>(lattice.At(plane)));
      cv::Mat sum = cv::Mat::zeros(size, CV_32FC1), count = cv::Mat::zeros(size, CV_32FC1);
      for (int i = 0; i < frames; ++i)
        for (int y = 0; y < size.height; ++y)
          AccumulateRow(level, i, y, w.data(), options.truncation, sum.ptr<float>(y),
                        count.ptr<float>(y));
      AggregateSlice(sum, count, frames, options);
      costs[plane] = sum;
    }
  });
  return costs;
}

std::vector<cv::Mat> SweepPlaneWindow(const SweepLevel& level, const InverseDepthLattice& lattice,
                                      const cv::Mat& first_plane, int count,
                                      const PhotoCostOptions& options) {
  CV_Assert(first_plane.type() == CV_32SC1 && first_plane.size() == level.reference.size());
  const int frames = static_cast<int>(level.frames.size());
  const cv::Size size = level.reference.size();
  std::vector<cv::Mat> sums(count), counts(count);
  for (int k = 0; k < count; ++k) {
    sums[k] = cv::Mat::zeros(size, CV_32FC1);
    counts[k] = cv::Mat::zeros(size, CV_32FC1);
  }
  const float w0 = static_cast<float>(lattice.min_inverse_depth);
  const float dw = static_cast<float>(lattice.step());
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    std::vector<float> w(size.width);
    for (int y = rows.start; y < rows.end; ++y) {
      const int* first = first_plane.ptr<int>(y);
      for (int k = 0; k < count; ++k) {
        for (int x = 0; x < size.width; ++x) w[x] = w0 + (first[x] + k) * dw;
        for (int i = 0; i < frames; ++i)
          AccumulateRow(level, i, y, w.data(), options.truncation, sums[k].ptr<float>(y),
                        counts[k].ptr<float>(y));
      }
    }
  });
  cv::parallel_for_(cv::Range(0, count), [&](const cv::Range& slices) {
    for (int k = slices.start; k < slices.end; ++k)
      AggregateSlice(sums[k], counts[k], frames, options);
  });
  return sums;
}

}  // namespace dfsm
