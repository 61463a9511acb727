#include "core/dense/plane_sweep.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "core/dense/row_projection.h"
#include "core/parallel/parallel_for.h"

namespace dfsm {
namespace {

#if CV_SIMD128
// The pixels at offset[lane] and offset[lane] + 1 of `data` for every lane,
// as two vectors. A pair is one 64-bit load: half the loads of four single
// lookups; the zips then sort the pairs' members into lanes. v_load_halves,
// not v_lut_pairs: SSE's v_lut_pairs dereferences an int64_t pointer, which
// UBSan rightly reports at the odd offsets a pair starts at; v_load_halves
// loads through the unaligned intrinsics (movq on SSE2, vld1 on NEON).
inline void LoadNeighbours(const float* data, const int* offset, cv::v_float32x4* left,
                           cv::v_float32x4* right) {
  // a = [l0 r0 l1 r1], b = [l2 r2 l3 r3]; zipped: [l0 l2 r0 r2], [l1 l3 r1 r3];
  // zipped again: [l0 l1 l2 l3], [r0 r1 r2 r3].
  const cv::v_float32x4 a = cv::v_load_halves(data + offset[0], data + offset[1]);
  const cv::v_float32x4 b = cv::v_load_halves(data + offset[2], data + offset[3]);
  cv::v_float32x4 c, d;
  cv::v_zip(a, b, c, d);
  cv::v_zip(c, d, *left, *right);
}
#endif

// Adds, for every pixel of reference row y, the truncated absolute
// difference between the reference and the bilinear sample of `image` to
// sum/count, where the sample is valid: usable in both projections and inside
// the frame. The sample lies a fraction `t` of the way from projection a to
// projection b of the row (b unread when t == 0). Positions are clamped, so
// the gather needs no branch.
//
// The sweeps spend most of their time here. Loads from computed addresses
// keep a compiler from vectorizing the loop, so it is written in OpenCV's
// universal intrinsics (SSE2 on x86-64, NEON on arm64): positions, weights
// and the cost in lanes, the four neighbours loaded through lookups. Each
// lane evaluates the scalar tail's expressions in the same order, so the two
// give the same bits (unless the compiler contracts to fused multiply-adds).
inline void GatherRow(const SweepLevel& level, const cv::Mat& image, int y, const RowSamples& a,
                      const RowSamples& b, float t, float truncation, float* sum, float* count) {
  const int cols = level.reference.cols;
  const float* ref = level.reference.ptr<float>(y);
  const float* ax = a.px.data();
  const float* ay = a.py.data();
  const float* au = a.usable.data();
  const float* bx = t == 0.0f ? ax : b.px.data();
  const float* by = t == 0.0f ? ay : b.py.data();
  const float* bu = t == 0.0f ? au : b.usable.data();
  const float* data = image.ptr<float>(0);
  const int stride = static_cast<int>(image.step1());
  // Bilinear needs (x0 + 1, y0 + 1) inside: clamp to just below the last pixel.
  const float max_x = image.cols - 1.001f, max_y = image.rows - 1.001f;
  int x = 0;
#if CV_SIMD128
  constexpr int kLanes = cv::v_float32x4::nlanes;
  const cv::v_float32x4 v_t = cv::v_setall_f32(t), v_truncation = cv::v_setall_f32(truncation);
  const cv::v_float32x4 zero = cv::v_setzero_f32(), one = cv::v_setall_f32(1.0f);
  const cv::v_float32x4 v_max_x = cv::v_setall_f32(max_x), v_max_y = cv::v_setall_f32(max_y);
  const cv::v_int32x4 v_stride = cv::v_setall_s32(stride);
  alignas(64) int offset[kLanes];
  for (; x + kLanes <= cols; x += kLanes) {
    const cv::v_float32x4 ax_ = cv::v_load(ax + x), ay_ = cv::v_load(ay + x);
    const cv::v_float32x4 px = ax_ + v_t * (cv::v_load(bx + x) - ax_);
    const cv::v_float32x4 py = ay_ + v_t * (cv::v_load(by + x) - ay_);
    const cv::v_float32x4 inside = (cv::v_load(au + x) * cv::v_load(bu + x) > zero) & (px >= zero) &
                                   (py >= zero) & (px <= v_max_x) & (py <= v_max_y);
    const cv::v_float32x4 valid = one & inside;
    const cv::v_float32x4 sx = cv::v_min(cv::v_max(px, zero), v_max_x);
    const cv::v_float32x4 sy = cv::v_min(cv::v_max(py, zero), v_max_y);
    const cv::v_int32x4 x0 = cv::v_trunc(sx), y0 = cv::v_trunc(sy);
    const cv::v_float32x4 fx = sx - cv::v_cvt_f32(x0), fy = sy - cv::v_cvt_f32(y0);
    cv::v_store_aligned(offset, y0 * v_stride + x0);
    cv::v_float32x4 p0, p1, q0, q1;
    LoadNeighbours(data, offset, &p0, &p1);
    LoadNeighbours(data + stride, offset, &q0, &q1);
    const cv::v_float32x4 top = p0 + fx * (p1 - p0);
    const cv::v_float32x4 bottom = q0 + fx * (q1 - q0);
    const cv::v_float32x4 value = top + fy * (bottom - top);
    const cv::v_float32x4 difference =
        cv::v_min(cv::v_abs(value - cv::v_load(ref + x)), v_truncation);
    cv::v_store(sum + x, cv::v_load(sum + x) + valid * difference);
    cv::v_store(count + x, cv::v_load(count + x) + valid);
  }
#endif
  for (; x < cols; ++x) {
    const float px = ax[x] + t * (bx[x] - ax[x]), py = ay[x] + t * (by[x] - ay[x]);
    // Bitwise & (no short circuit) keeps the loop free of branches.
    const bool inside =
        (au[x] * bu[x] > 0.0f) & (px >= 0.0f) & (py >= 0.0f) & (px <= max_x) & (py <= max_y);
    const float valid = inside ? 1.0f : 0.0f;
    const float sx = std::min(std::max(px, 0.0f), max_x);
    const float sy = std::min(std::max(py, 0.0f), max_y);
    const int x0 = static_cast<int>(sx), y0 = static_cast<int>(sy);
    const float fx = sx - x0, fy = sy - y0;
    const float* p = data + y0 * stride + x0;
    const float* q = p + stride;
    const float top = p[0] + fx * (p[1] - p[0]);
    const float bottom = q[0] + fx * (q[1] - q[0]);
    const float value = top + fy * (bottom - top);
    sum[x] += valid * std::min(std::abs(value - ref[x]), truncation);
    count[x] += valid;
  }
}

// Box sums of one slice's sum and count over square windows of `radius`.
struct WindowSums {
  cv::Mat sum, count;
  float min_count = 0.0f;  // fewer valid samples than this: kNoCost

  WindowSums(const cv::Mat& slice_sum, const cv::Mat& slice_count, int radius, int frames,
             const PhotoCostOptions& options) {
    const cv::Size window(2 * radius + 1, 2 * radius + 1);
    cv::boxFilter(slice_sum, sum, -1, window, cv::Point(-1, -1), false, cv::BORDER_REPLICATE);
    cv::boxFilter(slice_count, count, -1, window, cv::Point(-1, -1), false, cv::BORDER_REPLICATE);
    min_count = options.min_valid_share * frames * window.area();
  }
};

// Aggregates one slice's sum and count into its mean cost: over the wide
// window where `wide_mask` (band-sized, or empty: nowhere) is set, the
// narrow one elsewhere; then the lowest over the shiftable windows.
cv::Mat AggregateSlice(const cv::Mat& sum, const cv::Mat& count, int frames,
                       const PhotoCostOptions& options, const cv::Mat& wide_mask) {
  const WindowSums narrow(sum, count, options.window_radius, frames, options);
  cv::Mat cost(sum.size(), CV_32FC1);
  if (wide_mask.empty()) {
    for (int y = 0; y < cost.rows; ++y) {
      const float* s = narrow.sum.ptr<float>(y);
      const float* c = narrow.count.ptr<float>(y);
      float* out = cost.ptr<float>(y);
      for (int x = 0; x < cost.cols; ++x) out[x] = c[x] >= narrow.min_count ? s[x] / c[x] : kNoCost;
    }
  } else {
    const WindowSums wide(sum, count, options.wide_window_radius, frames, options);
    for (int y = 0; y < cost.rows; ++y) {
      const float* s1 = narrow.sum.ptr<float>(y);
      const float* c1 = narrow.count.ptr<float>(y);
      const float* s2 = wide.sum.ptr<float>(y);
      const float* c2 = wide.count.ptr<float>(y);
      const uchar* m = wide_mask.ptr<uchar>(y);
      float* out = cost.ptr<float>(y);
      for (int x = 0; x < cost.cols; ++x) {
        const bool use_wide = m[x] != 0;
        const float s = use_wide ? s2[x] : s1[x];
        const float c = use_wide ? c2[x] : c1[x];
        out[x] = c >= (use_wide ? wide.min_count : narrow.min_count) ? s / c : kNoCost;
      }
    }
  }
  if (options.shiftable_radius > 0) {
    const int side = 2 * options.shiftable_radius + 1;
    cv::erode(cost, cost, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(side, side)),
              cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  }
  return cost;
}

// Rows [first, last) of the level, swept with `halo` more rows on each side:
// band row j is level row Row(j). Clamping the halo into the image repeats
// the edge rows, so aggregating the band with a replicated border gives its
// inner rows exactly what aggregating the whole image would (the halo covers
// the box and the shiftable windows; at the image's first and last rows the
// shiftable windows also reach windows centred on the repeated rows).
struct Band {
  int first = 0, last = 0, halo = 0, level_rows = 0;
  int rows() const { return last - first + 2 * halo; }
  int Row(int j) const { return std::clamp(first - halo + j, 0, level_rows - 1); }
  // The inner rows of a band-sized image.
  cv::Mat Inner(const cv::Mat& band_image) const {
    return band_image.rowRange(halo, halo + last - first);
  }
};

void CheckWideWindowMask(const SweepLevel& level, const PhotoCostOptions& options) {
  const cv::Mat& mask = options.wide_window_mask;
  CV_Assert(options.wide_window_radius >= 0);
  CV_Assert(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == level.reference.size()));
}

// Rows a band must sweep beyond its own for its windows to aggregate exactly.
int Halo(const PhotoCostOptions& options) {
  const int wide = options.wide_window_mask.empty() ? 0 : options.wide_window_radius;
  return std::max(options.window_radius, wide) + options.shiftable_radius;
}

// Calls sweep_band(band) for bands covering the level's rows, in parallel.
// Bands are small enough that every core gets several (balance) and large
// enough that the halo adds little (16-128 rows against 2 x 7 rows for the
// wide windows: at 1080p on 2 cores, 128-row bands swept the full-resolution
// window ~5 % faster than 64-row ones; a band of 7 slices is ~15 MB), and as
// many for every thread (RowBandLayout).
template <typename SweepBand>
void ForEachBand(int level_rows, int halo, const SweepBand& sweep_band) {
  constexpr int kMaxBandRows = 128;
  if (level_rows <= 0) return;
  const int threads = std::max(1, cv::getNumThreads());
  const int band_rows =
      std::clamp(level_rows / (4 * threads), RowBandLayout::kMinSpreadRows, kMaxBandRows);
  // The sweep's halo repeats the edge rows (Band::Row), so the RowBand's
  // clamped halo is not used.
  ForEachRowBand(level_rows, band_rows, 0, [&](const RowBand& rows) {
    Band band;
    band.first = rows.first;
    band.last = rows.last;
    band.halo = halo;
    band.level_rows = level_rows;
    sweep_band(band);
  });
}

// Views of the rows [first, last) of a full-level selection.
PlaneSelection SelectionRows(PlaneSelection& selection, const Band& band) {
  return {selection.plane.rowRange(band.first, band.last),
          selection.confidence.rowRange(band.first, band.last),
          selection.at_edge.rowRange(band.first, band.last)};
}

PlaneSelection MakeSelection(const cv::Size& size) {
  return {cv::Mat(size, CV_32FC1), cv::Mat(size, CV_32FC1), cv::Mat(size, CV_8UC1)};
}

// The sum and count slices of one band, one pair per swept plane: filled row
// by row by GatherRow, then aggregated and selected as a whole.
struct BandSlices {
  std::vector<cv::Mat> sums, counts;

  BandSlices(int slices, const cv::Size& band_size) : sums(slices), counts(slices) {
    for (int k = 0; k < slices; ++k) {
      sums[k] = cv::Mat::zeros(band_size, CV_32FC1);
      counts[k] = cv::Mat::zeros(band_size, CV_32FC1);
    }
  }

  // Turns every slice into its mean cost over the band's inner rows.
  void Aggregate(const Band& band, int frames, const PhotoCostOptions& options) {
    cv::Mat wide_mask;
    if (options.wide_window_radius > 0 && !options.wide_window_mask.empty()) {
      wide_mask.create(band.rows(), options.wide_window_mask.cols, CV_8UC1);
      for (int j = 0; j < band.rows(); ++j)
        options.wide_window_mask.row(band.Row(j)).copyTo(wide_mask.row(j));
      if (cv::countNonZero(wide_mask) == 0) wide_mask.release();  // all textured
    }
    for (size_t k = 0; k < sums.size(); ++k)
      sums[k] = band.Inner(AggregateSlice(sums[k], counts[k], frames, options, wide_mask));
  }

  // Aggregates, then selects the band's inner rows into `selection`
  // (first_plane: the level's, or empty; see SelectPlanes).
  void Select(const Band& band, int frames, const PhotoCostOptions& options,
              const cv::Mat& first_plane, int stride, PlaneSelection& selection) {
    Aggregate(band, frames, options);
    PlaneSelection rows = SelectionRows(selection, band);
    SeedPrior prior = options.seed_prior;
    if (prior.weight > 0.0f) prior.seed = prior.seed.rowRange(band.first, band.last);
    SelectPlanesNearSeedInto(
        sums, first_plane.empty() ? cv::Mat() : first_plane.rowRange(band.first, band.last), stride,
        prior, &rows);
  }
};

// Sweeps every plane of the lattice band by band; each band's slices, once
// gathered, go to finish_band(band, slices).
template <typename FinishBand>
void SweepEveryPlane(const SweepLevel& level, const InverseDepthLattice& lattice,
                     const PhotoCostOptions& options, const FinishBand& finish_band) {
  CV_Assert(options.projected_every >= 1);
  CV_Assert(options.seed_prior.weight <= 0.0f);  // a prior is SweepPlaneWindow's
  CheckWideWindowMask(level, options);
  const int frames = static_cast<int>(level.frames.size());
  const cv::Size size = level.reference.size();
  const int planes = lattice.planes;
  // Projected planes: every projected_every-th one and the last. Plane p is
  // interpolated between projections segment[p] and segment[p] + 1.
  std::vector<int> projected;
  for (int p = 0; p < planes - 1; p += options.projected_every) projected.push_back(p);
  projected.push_back(planes - 1);
  std::vector<int> segment(planes);
  std::vector<float> along(planes);
  for (int p = 0, k = 0; p < planes; ++p) {
    while (k + 2 < static_cast<int>(projected.size()) && projected[k + 1] <= p) ++k;
    segment[p] = k;
    const int span = projected.size() > 1 ? projected[k + 1] - projected[k] : 1;
    along[p] = static_cast<float>(p - projected[k]) / span;
  }
  if (projected.size() == 1) projected.push_back(projected[0]);  // one plane: no segment
  ForEachBand(size.height, Halo(options), [&](const Band& band) {
    const cv::Size band_size(size.width, band.rows());
    std::vector<std::vector<float>> w(projected.size(), std::vector<float>(size.width));
    for (size_t k = 0; k < projected.size(); ++k)
      std::fill(w[k].begin(), w[k].end(), static_cast<float>(lattice.At(projected[k])));
    std::vector<RowSamples> samples(projected.size(), RowSamples(size.width));
    BandSlices slices(planes, band_size);
    for (int j = 0; j < band.rows(); ++j) {
      const int y = band.Row(j);
      for (int i = 0; i < frames; ++i) {
        for (size_t k = 0; k < projected.size(); ++k)
          ProjectRow(level, i, y, w[k].data(), &samples[k]);
        for (int p = 0; p < planes; ++p) {
          GatherRow(level, level.frames[i], y, samples[segment[p]], samples[segment[p] + 1],
                    along[p], options.truncation, slices.sums[p].ptr<float>(j),
                    slices.counts[p].ptr<float>(j));
        }
      }
    }
    finish_band(band, slices);
  });
}

}  // namespace

PlaneSelection SweepAllPlanes(const SweepLevel& level, const InverseDepthLattice& lattice,
                              const PhotoCostOptions& options) {
  const int frames = static_cast<int>(level.frames.size());
  PlaneSelection selection = MakeSelection(level.reference.size());
  SweepEveryPlane(level, lattice, options, [&](const Band& band, BandSlices& slices) {
    slices.Select(band, frames, options, {}, 1, selection);
  });
  return selection;
}

std::vector<cv::Mat> SweepAllPlaneCosts(const SweepLevel& level, const InverseDepthLattice& lattice,
                                        const PhotoCostOptions& options) {
  const int frames = static_cast<int>(level.frames.size());
  std::vector<cv::Mat> costs(lattice.planes);
  for (cv::Mat& slice : costs) slice.create(level.reference.size(), CV_32FC1);
  SweepEveryPlane(level, lattice, options, [&](const Band& band, BandSlices& slices) {
    slices.Aggregate(band, frames, options);
    for (int p = 0; p < lattice.planes; ++p)
      slices.sums[p].copyTo(costs[p].rowRange(band.first, band.last));
  });
  return costs;
}

PlaneSelection SweepPlaneWindow(const SweepLevel& level, const InverseDepthLattice& lattice,
                                const cv::Mat& first_plane, int count, int stride,
                                const PhotoCostOptions& options) {
  CV_Assert(first_plane.type() == CV_32SC1 && first_plane.size() == level.reference.size());
  CV_Assert(options.seed_prior.weight <= 0.0f ||
            (options.seed_prior.seed.size() == level.reference.size() &&
             options.seed_prior.seed.type() == CV_32FC1));
  CheckWideWindowMask(level, options);
  const int frames = static_cast<int>(level.frames.size());
  const cv::Size size = level.reference.size();
  const float w0 = static_cast<float>(lattice.min_inverse_depth);
  const float dw = static_cast<float>(lattice.step());
  PlaneSelection selection = MakeSelection(size);
  ForEachBand(size.height, Halo(options), [&](const Band& band) {
    const cv::Size band_size(size.width, band.rows());
    std::vector<float> w_first(size.width), w_last(size.width);
    RowSamples first_samples(size.width), last_samples(size.width);
    BandSlices slices(count, band_size);
    // The window's planes are evenly spaced in w, and along them a sample
    // moves on a straight line to within ~0.02 pixel: the homography is
    // linear in w up to the division by Z, which changes by well under 1 %
    // across a window of a few pixels of parallax, and the U->D polynomial is
    // smooth at that scale. So only the window's two end planes are projected
    // and the planes between are interpolated, which takes the arithmetic
    // (about half of the sweep) off every plane but two.
    const float last_t = count > 1 ? 1.0f / (count - 1) : 0.0f;
    for (int j = 0; j < band.rows(); ++j) {
      const int y = band.Row(j);
      const int* first = first_plane.ptr<int>(y);
      for (int x = 0; x < size.width; ++x) {
        w_first[x] = w0 + first[x] * dw;
        w_last[x] = w0 + (first[x] + (count - 1) * stride) * dw;
      }
      for (int i = 0; i < frames; ++i) {
        ProjectRow(level, i, y, w_first.data(), &first_samples);
        if (count > 1) ProjectRow(level, i, y, w_last.data(), &last_samples);
        for (int k = 0; k < count; ++k) {
          GatherRow(level, level.frames[i], y, first_samples, last_samples, k * last_t,
                    options.truncation, slices.sums[k].ptr<float>(j),
                    slices.counts[k].ptr<float>(j));
        }
      }
    }
    slices.Select(band, frames, options, first_plane, stride, selection);
  });
  return selection;
}

}  // namespace dfsm
