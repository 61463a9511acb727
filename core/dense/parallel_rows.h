// Row-parallel loops over images: every per-pixel pass of the dense stage is
// independent across rows, and a serial 2-megapixel pass costs as much as a
// sub-stage on a 2-core device.
#pragma once

#include <opencv2/core/utility.hpp>

namespace dfsm {

// Calls row(y) for y in [0, rows), in parallel (cv::parallel_for_).
template <typename RowFunction>
void ParallelRows(int rows, const RowFunction& row) {
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) row(y);
  });
}

}  // namespace dfsm
