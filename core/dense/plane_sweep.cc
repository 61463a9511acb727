#include "core/dense/plane_sweep.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace dfsm {
namespace {

// Per-worker row buffers of AccumulateRow.
struct RowScratch {
  explicit RowScratch(int cols) : x(cols), y(cols), valid(cols) {}
  std::vector<float> x, y, valid;
};

// Adds, for one row of the reference and one frame, the truncated absolute
// difference at inverse depth w[x] to sum/count. Two passes so that the
// first, all arithmetic (homography, U->D polynomial, bounds), vectorizes;
// the second is the bilinear gather, branch-free on clamped coordinates.
inline void AccumulateRow(const SweepLevel& level, int frame, int y, const float* w,
                          float truncation, RowScratch* scratch, float* sum, float* count) {
  const PlaneHomography& h = level.warps[frame];
  const cv::Mat& image = level.frames[frame];
  const int cols = level.reference.cols;
  const float* rx = level.ray_x.ptr<float>(y);
  const float* ry = level.ray_y.ptr<float>(y);
  const float* ref = level.reference.ptr<float>(y);
  const RadialInverse& radial = *level.radial;
  const float max_r2 = radial.max_r2();
  // Bilinear needs (x0 + 1, y0 + 1) inside: clamp to just below the last pixel.
  const float max_x = image.cols - 1.001f, max_y = image.rows - 1.001f;
  const float focal = level.focal, centre_x = level.centre_x, centre_y = level.centre_y;
  float* sx = scratch->x.data();
  float* sy = scratch->y.data();
  float* valid = scratch->valid.data();
  // Locals, so the compiler need not fear that the stores below alias them.
  const float r0 = h.r[0], r1 = h.r[1], r2_ = h.r[2], r3 = h.r[3], r4 = h.r[4], r5 = h.r[5];
  const float r6 = h.r[6], r7 = h.r[7], r8 = h.r[8], t0 = h.t[0], t1 = h.t[1], t2 = h.t[2];
  for (int x = 0; x < cols; ++x) {
    const float X = r0 * rx[x] + r1 * ry[x] + r2_ + w[x] * t0;
    const float Y = r3 * rx[x] + r4 * ry[x] + r5 + w[x] * t1;
    const float Z = r6 * rx[x] + r7 * ry[x] + r8 + w[x] * t2;
    // (Vectorizes only with -fno-trapping-math, set for this file.)
    const float inv = 1.0f / (Z > 1e-6f ? Z : 1.0f);
    const float x_u = X * inv, y_u = Y * inv;
    const float r2 = x_u * x_u + y_u * y_u;
    const float scaled = focal * radial.Ratio(std::min(r2, max_r2));
    const float px = centre_x + scaled * x_u, py = centre_y + scaled * y_u;
    // Bitwise & (no short circuit) keeps the loop free of branches.
    const bool inside =
        (Z > 1e-6f) & (r2 <= max_r2) & (px >= 0.0f) & (py >= 0.0f) & (px <= max_x) & (py <= max_y);
    valid[x] = inside ? 1.0f : 0.0f;
    sx[x] = std::min(std::max(px, 0.0f), max_x);
    sy[x] = std::min(std::max(py, 0.0f), max_y);
  }
  const float* data = image.ptr<float>(0);
  const size_t stride = image.step1();
  for (int x = 0; x < cols; ++x) {
    const int x0 = static_cast<int>(sx[x]), y0 = static_cast<int>(sy[x]);
    const float fx = sx[x] - x0, fy = sy[x] - y0;
    const float* p = data + y0 * stride + x0;
    const float* q = p + stride;
    const float top = p[0] + fx * (p[1] - p[0]);
    const float bottom = q[0] + fx * (q[1] - q[0]);
    const float value = top + fy * (bottom - top);
    sum[x] += valid[x] * std::min(std::abs(value - ref[x]), truncation);
    count[x] += valid[x];
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
    RowScratch scratch(size.width);
    for (int plane = planes.start; plane < planes.end; ++plane) {
      std::fill(w.begin(), w.end(), static_cast<float>(lattice.At(plane)));
      cv::Mat sum = cv::Mat::zeros(size, CV_32FC1), count = cv::Mat::zeros(size, CV_32FC1);
      for (int i = 0; i < frames; ++i)
        for (int y = 0; y < size.height; ++y)
          AccumulateRow(level, i, y, w.data(), options.truncation, &scratch, sum.ptr<float>(y),
                        count.ptr<float>(y));
      AggregateSlice(sum, count, frames, options);
      costs[plane] = sum;
    }
  });
  return costs;
}

std::vector<cv::Mat> SweepPlaneWindow(const SweepLevel& level, const InverseDepthLattice& lattice,
                                      const cv::Mat& first_plane, int count, int stride,
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
    RowScratch scratch(size.width);
    for (int y = rows.start; y < rows.end; ++y) {
      const int* first = first_plane.ptr<int>(y);
      for (int k = 0; k < count; ++k) {
        for (int x = 0; x < size.width; ++x) w[x] = w0 + (first[x] + k * stride) * dw;
        for (int i = 0; i < frames; ++i)
          AccumulateRow(level, i, y, w.data(), options.truncation, &scratch, sums[k].ptr<float>(y),
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
