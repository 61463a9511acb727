#include "core/dense/semi_global.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core/hal/intrin.hpp>
#include <stdexcept>
#include <string>

#include "core/dense/plane_selection.h"
#include "core/dense/plane_sweep.h"

namespace dfsm {

void SemiGlobalOptions::Check() const {
  const auto require = [](bool condition, const std::string& what) {
    if (!condition) throw std::invalid_argument("semi-global aggregation: " + what);
  };
  require(std::isfinite(small_step_penalty) && small_step_penalty >= 0.0f,
          "small_step_penalty must be >= 0");
  require(std::isfinite(large_step_penalty) && large_step_penalty >= small_step_penalty,
          "large_step_penalty must be >= small_step_penalty");
  require(std::isfinite(edge_gradient) && edge_gradient > 0.0f, "edge_gradient must be > 0");
}

namespace {

// min_d values[d], through OpenCV's universal intrinsics: the compiler keeps
// a float minimum reduction scalar, and it is a third of a path step.
inline float Lowest(const float* values, int depth) {
  int d = 0;
  float lowest = values[0];
#if CV_SIMD
  constexpr int kLanes = cv::v_float32::nlanes;
  if (depth >= kLanes) {
    cv::v_float32 lanes = cv::vx_load(values);
    for (d = kLanes; d + kLanes <= depth; d += kLanes)
      lanes = cv::v_min(lanes, cv::vx_load(values + d));
    lowest = cv::v_reduce_min(lanes);
  }
#endif
  for (; d < depth; ++d) lowest = std::min(lowest, values[d]);
  return lowest;
}

// One step along a path r (Hirschmueller's eq. 13):
//   L_r(p, d) = C(p, d) + min(L_r(q, d), L_r(q, d -+ 1) + P1, min_k L_r(q, k) + P2)
//               - min_k L_r(q, k),
// q the previous pixel on the path. Subtracting min_k L_r(q, k) keeps L_r
// bounded by C + P2 however long the path. Writes L_r(p, .) to `out`, adds
// it to `sum` and returns its minimum.
inline float PathStep(const float* cost, const float* previous, float previous_min, float p1,
                      float p2, int depth, float* out, float* sum) {
  const float jump = previous_min + p2;
  const auto finish = [&](int d, float best) {
    const float l = cost[d] + best - previous_min;
    out[d] = l;
    sum[d] += l;
  };
  finish(0, std::min(std::min(previous[0], previous[1] + p1), jump));
  for (int d = 1; d < depth - 1; ++d)
    finish(d,
           std::min(std::min(previous[d], jump), std::min(previous[d - 1], previous[d + 1]) + p1));
  finish(depth - 1, std::min(std::min(previous[depth - 1], previous[depth - 2] + p1), jump));
  return Lowest(out, depth);
}

// The first pixel of a path: L_r(p, .) = C(p, .).
inline float PathStart(const float* cost, int depth, float* out, float* sum) {
  for (int d = 0; d < depth; ++d) {
    out[d] = cost[d];
    sum[d] += cost[d];
  }
  return Lowest(cost, depth);
}

// The volume's geometry and the per-row helpers shared by the passes.
struct Volume {
  const std::vector<cv::Mat>& costs;
  const cv::Mat& guide;
  const SemiGlobalOptions& options;
  float missing_cost;  // along a path, for a plane without a cost
  int rows, cols, depth;
  std::vector<float> sums;  // pixel-major: (y * cols + x) * depth + d

  float* Sum(int y, int x) { return sums.data() + (static_cast<size_t>(y) * cols + x) * depth; }

  // Row y's costs pixel-major into `row` (cols x depth), unseen planes at
  // missing_cost, columns [begin, end) only.
  void GatherRow(int y, int begin, int end, float* row) const {
    for (int d = 0; d < depth; ++d) {
      const float* slice = costs[d].ptr<float>(y);
      for (int x = begin; x < end; ++x)
        row[static_cast<size_t>(x) * depth + d] = std::min(slice[x], missing_cost);
    }
  }

  // P2 between neighbours whose guide values are a and b.
  float LargeStep(float a, float b) const {
    const float g = options.edge_gradient;
    return std::max(options.small_step_penalty,
                    options.large_step_penalty * g / (g + std::abs(a - b)));
  }
};

// The two paths along rows (left to right and right to left); rows are
// independent, so they run in parallel. Initializes the sums.
void RowPaths(Volume& volume) {
  const int cols = volume.cols, depth = volume.depth;
  std::fill(volume.sums.begin(), volume.sums.end(), 0.0f);
  cv::parallel_for_(cv::Range(0, volume.rows), [&](const cv::Range& range) {
    std::vector<float> row(static_cast<size_t>(cols) * depth), a(depth), b(depth);
    for (int y = range.start; y < range.end; ++y) {
      volume.GatherRow(y, 0, cols, row.data());
      const float* g = volume.guide.ptr<float>(y);
      const float p1 = volume.options.small_step_penalty;
      float lowest = PathStart(row.data(), depth, a.data(), volume.Sum(y, 0));
      for (int x = 1; x < cols; ++x) {
        lowest = PathStep(&row[static_cast<size_t>(x) * depth], a.data(), lowest, p1,
                          volume.LargeStep(g[x], g[x - 1]), depth, b.data(), volume.Sum(y, x));
        std::swap(a, b);
      }
      lowest = PathStart(&row[static_cast<size_t>(cols - 1) * depth], depth, a.data(),
                         volume.Sum(y, cols - 1));
      for (int x = cols - 2; x >= 0; --x) {
        lowest = PathStep(&row[static_cast<size_t>(x) * depth], a.data(), lowest, p1,
                          volume.LargeStep(g[x], g[x + 1]), depth, b.data(), volume.Sum(y, x));
        std::swap(a, b);
      }
    }
  });
}

// The three paths that come from the row before (vertical and the two
// diagonals), row after row from `first_row` in direction `step` (+1: from
// the top, -1: from the bottom). Each row depends on the previous one; its
// pixels run in parallel.
void ColumnPaths(Volume& volume, int first_row, int step) {
  const int cols = volume.cols, depth = volume.depth;
  const size_t row_size = static_cast<size_t>(cols) * depth;
  // Per direction dx (the previous pixel is (y - step, x + dx)): the path
  // costs and their minima along the previous row and the current one.
  constexpr int kDirections = 3;
  std::vector<float> previous(kDirections * row_size), current(kDirections * row_size);
  std::vector<float> previous_min(kDirections * cols), current_min(kDirections * cols);
  std::vector<float> row(row_size);
  const float p1 = volume.options.small_step_penalty;
  for (int n = 0, y = first_row; n < volume.rows; ++n, y += step) {
    const float* g = volume.guide.ptr<float>(y);
    const float* g_previous = n > 0 ? volume.guide.ptr<float>(y - step) : nullptr;
    cv::parallel_for_(
        cv::Range(0, cols),
        [&](const cv::Range& range) {
          volume.GatherRow(y, range.start, range.end, row.data());
          for (int x = range.start; x < range.end; ++x) {
            const float* cost = &row[static_cast<size_t>(x) * depth];
            float* sum = volume.Sum(y, x);
            for (int r = 0; r < kDirections; ++r) {
              const int dx = r - 1, q = x + dx;
              float* out = &current[r * row_size + static_cast<size_t>(x) * depth];
              float& lowest = current_min[r * cols + x];
              if (n == 0 || q < 0 || q >= cols) {
                lowest = PathStart(cost, depth, out, sum);
              } else {
                lowest = PathStep(cost, &previous[r * row_size + static_cast<size_t>(q) * depth],
                                  previous_min[r * cols + q], p1,
                                  volume.LargeStep(g[x], g_previous[q]), depth, out, sum);
              }
            }
          }
        },
        std::max(1, cv::getNumThreads()));
    std::swap(previous, current);
    std::swap(previous_min, current_min);
  }
}

}  // namespace

PlaneSelection SelectSemiGlobal(const std::vector<cv::Mat>& costs, const cv::Mat& guide,
                                float missing_cost, const SemiGlobalOptions& options) {
  options.Check();
  if (!(std::isfinite(missing_cost) && missing_cost > 0.0f))
    throw std::invalid_argument("semi-global aggregation: missing_cost must be > 0");
  const int depth = static_cast<int>(costs.size());
  CV_Assert(depth >= 1 && guide.type() == CV_32FC1);
  for (const cv::Mat& slice : costs)
    CV_Assert(slice.type() == CV_32FC1 && slice.size() == guide.size());
  if (depth < 2) return SelectPlanes(costs);  // one plane: nothing to choose between
  Volume volume{costs, guide, options, missing_cost, guide.rows, guide.cols, depth, {}};
  volume.sums.resize(static_cast<size_t>(volume.rows) * volume.cols * depth);
  RowPaths(volume);
  ColumnPaths(volume, 0, 1);
  ColumnPaths(volume, volume.rows - 1, -1);
  PlaneSelection selection{cv::Mat(guide.size(), CV_32FC1), cv::Mat(guide.size(), CV_32FC1),
                           cv::Mat(guide.size(), CV_8UC1)};
  // Winners straight from the pixel-major sums (each pixel's curve is
  // contiguous there), planes without a cost put back to kNoCost first.
  cv::parallel_for_(cv::Range(0, volume.rows), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      for (int d = 0; d < depth; ++d) {
        const float* raw = costs[d].ptr<float>(y);
        for (int x = 0; x < volume.cols; ++x)
          if (raw[x] >= kNoCost) volume.Sum(y, x)[d] = kNoCost;
      }
      float* plane = selection.plane.ptr<float>(y);
      float* confidence = selection.confidence.ptr<float>(y);
      uchar* at_edge = selection.at_edge.ptr<uchar>(y);
      for (int x = 0; x < volume.cols; ++x)
        SelectCurve(volume.Sum(y, x), depth, 0, 1, &plane[x], &confidence[x], &at_edge[x]);
    }
  });
  return selection;
}

}  // namespace dfsm
