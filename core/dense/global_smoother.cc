#include "core/dense/global_smoother.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core/hal/intrin.hpp>
#include <stdexcept>
#include <vector>

namespace dfsm {
namespace {

// exp(-|b - a| / sigma), elementwise: the pull between the neighbours of two
// views of the guide shifted by one pixel; for several channels |b - a| is
// the largest of theirs.
cv::Mat Affinity(const cv::Mat& a, const cv::Mat& b, double sigma) {
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  if (difference.channels() > 1) {
    std::vector<cv::Mat> channels;
    cv::split(difference, channels);
    difference = channels[0];
    for (size_t c = 1; c < channels.size(); ++c) cv::max(difference, channels[c], difference);
  }
  cv::Mat affinity;
  difference.convertTo(affinity, CV_32F, -1.0 / sigma);
  cv::exp(affinity, affinity);
  return affinity;
}

// Solves, for every column of every image on its own,
//   (1 + a(y-1) + a(y)) u(y) - a(y-1) u(y-1) - a(y) u(y+1) = f(y),
// a = lambda x affinity (0 beyond the ends), in place: the Thomas algorithm.
// The elimination's coefficients depend on the affinity alone, so they are
// computed once per column block for all images; every loop runs along a row,
// across columns, which the compiler vectorizes.
void SolveColumns(const cv::Mat& affinity, float lambda, const std::vector<cv::Mat*>& images) {
  const int rows = images.front()->rows, cols = images.front()->cols;
  if (rows < 2) return;
  constexpr int kBlock = 256;
  const int blocks = (cols + kBlock - 1) / kBlock;
  cv::parallel_for_(cv::Range(0, blocks), [&](const cv::Range& range) {
    std::vector<float> upper, inverse;  // c'(y) and 1 / m(y), rows x width
    for (int b = range.start; b < range.end; ++b) {
      const int x0 = b * kBlock, width = std::min(kBlock, cols - x0);
      upper.resize(static_cast<size_t>(rows) * width);
      inverse.resize(upper.size());
      // Forward elimination of the matrix.
      for (int y = 0; y < rows; ++y) {
        const float* below = y + 1 < rows ? affinity.ptr<float>(y) + x0 : nullptr;
        const float* above = y > 0 ? affinity.ptr<float>(y - 1) + x0 : nullptr;
        const float* c_prev = y > 0 ? &upper[(y - 1) * width] : nullptr;
        float* c = &upper[y * width];
        float* inv = &inverse[y * width];
        for (int x = 0; x < width; ++x) {
          const float a_next = below ? lambda * below[x] : 0.0f;
          const float a_prev = above ? lambda * above[x] : 0.0f;
          const float m = 1.0f + a_prev + a_next + (c_prev ? a_prev * c_prev[x] : 0.0f);
          inv[x] = 1.0f / m;
          c[x] = -a_next * inv[x];
        }
      }
      for (cv::Mat* image : images) {
        // Forward substitution, then back substitution, in place.
        for (int y = 0; y < rows; ++y) {
          float* d = image->ptr<float>(y) + x0;
          const float* inv = &inverse[y * width];
          if (y == 0) {
            for (int x = 0; x < width; ++x) d[x] *= inv[x];
            continue;
          }
          const float* above = affinity.ptr<float>(y - 1) + x0;
          const float* d_prev = image->ptr<float>(y - 1) + x0;
          for (int x = 0; x < width; ++x) d[x] = (d[x] + lambda * above[x] * d_prev[x]) * inv[x];
        }
        for (int y = rows - 2; y >= 0; --y) {
          float* u = image->ptr<float>(y) + x0;
          const float* u_next = image->ptr<float>(y + 1) + x0;
          const float* c = &upper[y * width];
          for (int x = 0; x < width; ++x) u[x] -= c[x] * u_next[x];
        }
      }
    }
  });
}

// Rows of an image in strips, interleaved x-major: strip[x * kLanes + k] is
// row k at x. Lanes of no row (a strip past the image's last row) hold 0.
constexpr int kLanes = 8;

// Copies the first `width` values of `lanes` rows into a strip, four columns of
// four rows at a time through a 4x4 transpose where the strip is full.
void Interleave(const float* const* rows, int lanes, int width, float* strip) {
  int x = 0;
#if CV_SIMD128
  if (lanes == kLanes) {
    for (; x + 4 <= width; x += 4) {
      for (int k = 0; k < kLanes; k += 4) {
        cv::v_float32x4 c0, c1, c2, c3;
        cv::v_transpose4x4(cv::v_load(rows[k] + x), cv::v_load(rows[k + 1] + x),
                           cv::v_load(rows[k + 2] + x), cv::v_load(rows[k + 3] + x), c0, c1, c2,
                           c3);
        cv::v_store(strip + x * kLanes + k, c0);
        cv::v_store(strip + (x + 1) * kLanes + k, c1);
        cv::v_store(strip + (x + 2) * kLanes + k, c2);
        cv::v_store(strip + (x + 3) * kLanes + k, c3);
      }
    }
  }
#endif
  for (; x < width; ++x) {
    for (int k = 0; k < lanes; ++k) strip[x * kLanes + k] = rows[k][x];
    for (int k = lanes; k < kLanes; ++k) strip[x * kLanes + k] = 0.0f;
  }
}

// The inverse of Interleave: the strip's lanes back into their rows.
void Deinterleave(const float* strip, int lanes, int width, float* const* rows) {
  int x = 0;
#if CV_SIMD128
  if (lanes == kLanes) {
    for (; x + 4 <= width; x += 4) {
      for (int k = 0; k < kLanes; k += 4) {
        cv::v_float32x4 r0, r1, r2, r3;
        cv::v_transpose4x4(cv::v_load(strip + x * kLanes + k),
                           cv::v_load(strip + (x + 1) * kLanes + k),
                           cv::v_load(strip + (x + 2) * kLanes + k),
                           cv::v_load(strip + (x + 3) * kLanes + k), r0, r1, r2, r3);
        cv::v_store(rows[k] + x, r0);
        cv::v_store(rows[k + 1] + x, r1);
        cv::v_store(rows[k + 2] + x, r2);
        cv::v_store(rows[k + 3] + x, r3);
      }
    }
  }
#endif
  for (; x < width; ++x)
    for (int k = 0; k < lanes; ++k) rows[k][x] = strip[x * kLanes + k];
}

// The same along every row. There the recursion runs along x: one row is a
// chain of dependent divisions, which no loop across x can vectorize. So
// kLanes rows go through it together, interleaved in a strip, and every step is
// a loop across the lanes, which the compiler vectorizes. Each lane does the
// arithmetic of one row alone, in the same order: the result is identical.
// Lanes of no row solve zeros and are never written back.
void SolveRows(const cv::Mat& affinity, float lambda, const std::vector<cv::Mat*>& images) {
  const int rows = images.front()->rows, cols = images.front()->cols;
  if (cols < 2) return;
  const int strips = (rows + kLanes - 1) / kLanes;
  cv::parallel_for_(cv::Range(0, strips), [&](const cv::Range& range) {
    const size_t size = static_cast<size_t>(cols) * kLanes;
    // pull(x): lambda a between x and x + 1 (0 at the last x); upper: c'(x);
    // inverse: 1 / m(x); d: the right-hand side, then the solution.
    std::vector<float> pull(size), upper(size), inverse(size), d(size);
    std::vector<const float*> affinity_rows(kLanes);
    std::vector<float*> lane_rows(kLanes);
    for (int strip = range.start; strip < range.end; ++strip) {
      const int y0 = strip * kLanes, lanes = std::min(kLanes, rows - y0);
      for (int k = 0; k < lanes; ++k) affinity_rows[k] = affinity.ptr<float>(y0 + k);
      Interleave(affinity_rows.data(), lanes, cols - 1, pull.data());
      for (size_t i = 0; i + kLanes < size; ++i) pull[i] *= lambda;
      std::fill(pull.end() - kLanes, pull.end(), 0.0f);
      // Forward elimination of the matrix (x = 0 has no left neighbour).
      for (int k = 0; k < kLanes; ++k) {
        inverse[k] = 1.0f / (1.0f + pull[k]);
        upper[k] = -pull[k] * inverse[k];
      }
      for (int x = 1; x < cols; ++x) {
        const float* a_prev = &pull[(x - 1) * kLanes];
        const float* c_prev = &upper[(x - 1) * kLanes];
        const float* a_next = &pull[x * kLanes];
        float* inv = &inverse[x * kLanes];
        float* c = &upper[x * kLanes];
        for (int k = 0; k < kLanes; ++k) {
          inv[k] = 1.0f / (1.0f + a_prev[k] + a_next[k] + a_prev[k] * c_prev[k]);
          c[k] = -a_next[k] * inv[k];
        }
      }
      for (cv::Mat* image : images) {
        for (int k = 0; k < lanes; ++k) lane_rows[k] = image->ptr<float>(y0 + k);
        Interleave(lane_rows.data(), lanes, cols, d.data());
        // Forward substitution, then back substitution, in place.
        for (int k = 0; k < kLanes; ++k) d[k] *= inverse[k];
        for (int x = 1; x < cols; ++x) {
          const float* a = &pull[(x - 1) * kLanes];
          const float* d_prev = &d[(x - 1) * kLanes];
          const float* inv = &inverse[x * kLanes];
          float* dx = &d[x * kLanes];
          for (int k = 0; k < kLanes; ++k) dx[k] = (dx[k] + a[k] * d_prev[k]) * inv[k];
        }
        for (int x = cols - 2; x >= 0; --x) {
          const float* c = &upper[x * kLanes];
          const float* d_next = &d[(x + 1) * kLanes];
          float* dx = &d[x * kLanes];
          for (int k = 0; k < kLanes; ++k) dx[k] -= c[k] * d_next[k];
        }
        Deinterleave(d.data(), lanes, cols, lane_rows.data());
      }
    }
  });
}

}  // namespace

void GlobalSmootherOptions::Check() const {
  if (!(lambda >= 0.0)) throw std::invalid_argument("lambda must be >= 0");
  if (!(sigma > 0.0)) throw std::invalid_argument("sigma must be > 0");
  if (!(color_sigma > 0.0)) throw std::invalid_argument("color_sigma must be > 0");
  if (iterations < 1) throw std::invalid_argument("iterations must be >= 1");
}

void SmoothAlongEdges(const cv::Mat& guide, const std::vector<cv::Mat*>& images,
                      const GlobalSmootherOptions& options) {
  options.Check();
  CV_Assert((guide.depth() == CV_8U || guide.depth() == CV_32F) &&
            (guide.channels() == 1 || guide.channels() == 3));
  for (const cv::Mat* image : images)
    CV_Assert(image->type() == CV_32FC1 && image->size() == guide.size());
  if (images.empty() || options.lambda == 0.0) return;
  const int rows = guide.rows, cols = guide.cols;
  const double sigma = guide.channels() == 1 ? options.sigma : options.color_sigma;
  // vertical(y, x): between (x, y) and (x, y + 1); horizontal(y, x): between
  // (x, y) and (x + 1, y). Empty where the image is one pixel high or wide.
  const cv::Mat vertical =
      rows > 1 ? Affinity(guide.rowRange(0, rows - 1), guide.rowRange(1, rows), sigma) : cv::Mat();
  const cv::Mat horizontal =
      cols > 1 ? Affinity(guide.colRange(0, cols - 1), guide.colRange(1, cols), sigma) : cv::Mat();
  // Min et al.'s schedule: lambda_t = 3/2 4^(T-1-t) / (4^T - 1) lambda, the
  // largest first; the passes of all iterations add up to lambda / 2.
  const int iterations = options.iterations;
  const double denominator = std::pow(4.0, iterations) - 1.0;
  for (int t = 0; t < iterations; ++t) {
    const float lambda =
        static_cast<float>(1.5 * options.lambda * std::pow(4.0, iterations - 1 - t) / denominator);
    SolveRows(horizontal, lambda, images);
    SolveColumns(vertical, lambda, images);
  }
}

}  // namespace dfsm
