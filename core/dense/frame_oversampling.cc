#include "core/dense/frame_oversampling.h"

#include <algorithm>
#include <vector>

#include "core/parallel/parallel_for.h"

namespace dfsm {
namespace {

// Catmull-Rom at t = 1/2: weights (-1, 9, 9, -1) / 16 on the pixels before,
// at, after and two after the half-way point.
inline float HalfWay(float before, float at, float after, float beyond) {
  return (9.0f * (at + after) - (before + beyond)) * (1.0f / 16.0f);
}

// One row of n samples onto 2 n - 1 nodes, edges replicated.
void OversampleRow(const float* in, int n, float* out) {
  for (int x = 0; x < n; ++x) out[2 * x] = in[x];
  for (int x = 0; x + 1 < n; ++x)
    out[2 * x + 1] = HalfWay(in[std::max(x - 1, 0)], in[x], in[x + 1], in[std::min(x + 2, n - 1)]);
}

}  // namespace

cv::Mat OversampleTwice(const cv::Mat& image) {
  CV_Assert(image.type() == CV_32FC1 && image.cols >= 1 && image.rows >= 1);
  const int cols = image.cols, rows = image.rows;
  cv::Mat out(2 * rows - 1, 2 * cols - 1, CV_32FC1);
  // Even rows: each source row along x.
  ParallelRows(rows,
               [&](int y) { OversampleRow(image.ptr<float>(y), cols, out.ptr<float>(2 * y)); });
  // Odd rows: half-way between the even rows above and below, column-wise
  // on whole rows so that the loop runs along memory.
  ParallelRows(rows - 1, [&](int y) {
    const float* before = out.ptr<float>(2 * std::max(y - 1, 0));
    const float* at = out.ptr<float>(2 * y);
    const float* after = out.ptr<float>(2 * y + 2);
    const float* beyond = out.ptr<float>(2 * std::min(y + 2, rows - 1));
    float* o = out.ptr<float>(2 * y + 1);
    for (int x = 0; x < out.cols; ++x) o[x] = HalfWay(before[x], at[x], after[x], beyond[x]);
  });
  return out;
}

}  // namespace dfsm
