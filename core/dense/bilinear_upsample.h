// Bilinear upsampling by an integer-ish factor, evaluated on the fly: the
// dense stage upsamples coarse maps only to read them once, row by row, so it
// computes each value where it is needed instead of materializing a
// full-resolution copy (8 MB per map at 1080p).
#pragma once

#include <algorithm>
#include <vector>

namespace dfsm {

// One axis of cv::resize's INTER_LINEAR alignment (pixel centres, edges
// replicated) from `small` samples to `covered` ones; indices from `covered`
// up to `full` (rows or columns an integer downsampling dropped) repeat the
// last covered one. Full index i reads small indices lower[i] and
// lower[i] + step[i] (step 0 at the last one) with weight t[i] on the second.
struct UpsampleAxis {
  std::vector<int> lower, step;
  std::vector<float> t;

  UpsampleAxis(int small, int covered, int full) : lower(full), step(full), t(full) {
    const double scale = static_cast<double>(small) / covered;
    for (int i = 0; i < full; ++i) {
      const double s = std::max(0.0, (std::min(i, covered - 1) + 0.5) * scale - 0.5);
      const int i0 = std::min(static_cast<int>(s), small - 1);
      lower[i] = i0;
      step[i] = i0 < small - 1 ? 1 : 0;
      t[i] = step[i] ? static_cast<float>(s - i0) : 0.0f;
    }
  }
  UpsampleAxis(int small, int full) : UpsampleAxis(small, full, full) {}
  // The small index nearest to full index i.
  int Nearest(int i) const { return t[i] < 0.5f ? lower[i] : lower[i] + step[i]; }
};

// The bilinear value at full-resolution column x of the small map whose rows
// r0 and r1 bracket the full-resolution row, ty of the way from r0 to r1.
inline float Upsampled(const float* r0, const float* r1, float ty, const UpsampleAxis& columns,
                       int x) {
  const int c0 = columns.lower[x], c1 = c0 + columns.step[x];
  const float tx = columns.t[x];
  const float top = r0[c0] + tx * (r0[c1] - r0[c0]);
  const float bottom = r1[c0] + tx * (r1[c1] - r1[c0]);
  return top + ty * (bottom - top);
}

}  // namespace dfsm
