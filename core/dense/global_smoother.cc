#include "core/dense/global_smoother.h"

#include <algorithm>
#include <cmath>
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

// The same along every row: the recursion runs along x, rows in parallel.
void SolveRows(const cv::Mat& affinity, float lambda, const std::vector<cv::Mat*>& images) {
  const int rows = images.front()->rows, cols = images.front()->cols;
  if (cols < 2) return;
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
    std::vector<float> upper(cols), inverse(cols);
    for (int y = range.start; y < range.end; ++y) {
      const float* a = affinity.ptr<float>(y);  // a[x]: between x and x + 1
      float c_prev = 0.0f, a_prev = 0.0f;
      for (int x = 0; x < cols; ++x) {
        const float a_next = x + 1 < cols ? lambda * a[x] : 0.0f;
        inverse[x] = 1.0f / (1.0f + a_prev + a_next + a_prev * c_prev);
        upper[x] = -a_next * inverse[x];
        c_prev = upper[x];
        a_prev = a_next;
      }
      for (cv::Mat* image : images) {
        float* d = image->ptr<float>(y);
        d[0] *= inverse[0];
        for (int x = 1; x < cols; ++x) d[x] = (d[x] + lambda * a[x - 1] * d[x - 1]) * inverse[x];
        for (int x = cols - 2; x >= 0; --x) d[x] -= upper[x] * d[x + 1];
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
