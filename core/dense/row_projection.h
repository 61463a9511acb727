// Where the plane sweep samples a frame: reference row y projected onto a
// frame of a SweepLevel at one inverse depth per pixel. Inline, so that the
// loops vectorize in the sweep's own translation unit (plane_sweep.cc, built
// with -fno-trapping-math); here for the tests to compare with the exact
// geometry.
#pragma once

#include <algorithm>
#include <vector>

#include "core/dense/sweep_level.h"

namespace dfsm {

// Sample positions of one reference row in one frame: the position (px, py)
// on the frames' grid (SweepLevel::oversample) and whether the ray met the plane in front of the
// frame inside the range where the U->D polynomial holds (1 or 0).
struct RowSamples {
  explicit RowSamples(int cols) : px(cols), py(cols), usable(cols) {}
  std::vector<float> px, py, usable;
};

// Projects reference row y onto `frame` at inverse depth w[x]: homography,
// then the U->D polynomial. Under a rolling shutter (`kRolling`) the sample
// moves on by the image motion over the rows between the row its pose is
// taken at and the row it landed on (PlaneHomography). All arithmetic, so it
// vectorizes (with -fno-trapping-math, set for plane_sweep.cc); positions
// stay finite where the sample is not usable.
template <bool kRolling>
inline void ProjectRowWith(const SweepLevel& level, int frame, int y, const float* w,
                           RowSamples* out) {
  const PlaneHomography& h = level.Warp(frame, y);
  const int cols = level.reference.cols;
  const float* rx = level.ray_x.ptr<float>(y);
  const float* ry = level.ray_y.ptr<float>(y);
  const RadialInverse& radial = *level.radial;
  const float max_r2 = radial.max_r2();
  // Onto the frames' grid (level pixels times the oversampling).
  const float grid = static_cast<float>(level.oversample);
  const float focal = grid * level.focal, centre_x = grid * level.centre_x,
              centre_y = grid * level.centre_y;
  float* px = out->px.data();
  float* py = out->py.data();
  float* usable = out->usable.data();
  // Locals, so the compiler need not fear that the stores below alias them.
  const float r0 = h.r[0], r1 = h.r[1], r2_ = h.r[2], r3 = h.r[3], r4 = h.r[4], r5 = h.r[5];
  const float r6 = h.r[6], r7 = h.r[7], r8 = h.r[8], t0 = h.t[0], t1 = h.t[1], t2 = h.t[2];
  const float row = h.row, gx0 = h.gx[0], gx1 = h.gx[1], gx2 = h.gx[2], gx3 = h.gx[3];
  const float gy0 = h.gy[0], gy1 = h.gy[1], gy2 = h.gy[2], gy3 = h.gy[3];
  for (int x = 0; x < cols; ++x) {
    const float X = r0 * rx[x] + r1 * ry[x] + r2_ + w[x] * t0;
    const float Y = r3 * rx[x] + r4 * ry[x] + r5 + w[x] * t1;
    const float Z = r6 * rx[x] + r7 * ry[x] + r8 + w[x] * t2;
    const float inv = 1.0f / (Z > 1e-6f ? Z : 1.0f);
    const float x_u = X * inv, y_u = Y * inv;
    const float r2 = x_u * x_u + y_u * y_u;
    const float scaled = focal * radial.Ratio(std::min(r2, max_r2));
    px[x] = centre_x + scaled * x_u;
    py[x] = centre_y + scaled * y_u;
    if constexpr (kRolling) {
      const float rows = py[x] - row;
      const float column = static_cast<float>(x);
      px[x] += rows * (gx0 + gx1 * column + w[x] * (gx2 + gx3 * column));
      py[x] += rows * (gy0 + gy1 * column + w[x] * (gy2 + gy3 * column));
    }
    // Bitwise & (no short circuit) keeps the loop free of branches.
    usable[x] = ((Z > 1e-6f) & (r2 <= max_r2)) ? 1.0f : 0.0f;
  }
}

// Picks the rolling shutter's loop or the global shutter's, which costs what
// it did before there was the other.
inline void ProjectRow(const SweepLevel& level, int frame, int y, const float* w, RowSamples* out) {
  if (level.rolling_shutter())
    ProjectRowWith<true>(level, frame, y, w, out);
  else
    ProjectRowWith<false>(level, frame, y, w, out);
}

}  // namespace dfsm
