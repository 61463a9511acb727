// The loops over OpenCV's thread pool, one place for all of them, so that
// the pipeline spreads over the cores the same way on x86-64 and arm64:
// independent tasks (RunInParallel), rows of an image (ParallelRows) and
// bands of rows with a halo (ForEachRowBand). SharedWork (shared_work.h)
// hands pieces of one stage to the idle cores of another.
#pragma once

#include <algorithm>
#include <exception>
#include <functional>
#include <opencv2/core/utility.hpp>
#include <vector>

namespace dfsm {

// Runs a handful of independent tasks (writing the files of one result, say)
// and returns when every task has run; rethrows the exception of the first
// task (in order) that threw, after all of them have finished.
inline void RunInParallel(const std::vector<std::function<void()>>& tasks) {
  // One task runs here: a parallel region would hold OpenCV's process-wide
  // nesting flag for its whole length and turn every other thread's
  // parallel_for_ serial meanwhile.
  if (tasks.size() == 1) return tasks.front()();
  std::vector<std::exception_ptr> errors(tasks.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(tasks.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      try {
        tasks[i]();
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
  });
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
}

// Calls row(y) for y in [0, rows), in parallel: every per-pixel pass of the
// dense stage is independent across rows, and a serial 2-megapixel pass
// costs as much as a sub-stage on a 2-core device.
template <typename RowFunction>
void ParallelRows(int rows, const RowFunction& row) {
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) row(y);
  });
}

// Bands of rows, for the filters OpenCV runs on one core and for the plane
// sweep: each band is filtered from its rows and a halo of rows on each
// side, and keeps its own rows. Over a whole 1080p frame such a filter also
// allocates its full-size temporaries afresh (fresh pages are dear); a
// band's are small.

// Rows [first, last) are the band's own; [from, to) adds up to `halo` rows
// on each side, clamped into the image.
struct RowBand {
  int first = 0, last = 0, from = 0, to = 0;
  // The band's own rows within the rows [from, to) it was filtered from.
  cv::Range Own() const { return cv::Range(first - from, last - from); }
};

// How `rows` rows are cut into bands for `threads` threads: bands of
// `band_rows` rows, the last one shorter. Where their count is no multiple
// of the threads, it is rounded up to one and the rows spread evenly over
// the bands, as long as each keeps kMinSpreadRows: otherwise the thread left
// with the last band works through it alone while the others wait (at 1080p
// on 2 cores, nine 128-row sweep bands took ~8 % longer than ten of 108;
// docs/experiments/208-sweep-bands-per-thread.md).
class RowBandLayout {
 public:
  static constexpr int kMinSpreadRows = 16;

  RowBandLayout(int rows, int band_rows, int threads)
      : rows_(std::max(0, rows)), band_rows_(std::max(1, band_rows)) {
    bands_ = (rows_ + band_rows_ - 1) / band_rows_;
    const int t = std::max(1, threads);
    const int balanced = (bands_ + t - 1) / t * t;
    spread_ = balanced != bands_ && rows_ / balanced >= kMinSpreadRows;
    if (spread_) bands_ = balanced;
  }

  int bands() const { return bands_; }
  // Band b's own rows.
  cv::Range Rows(int b) const {
    if (spread_) return cv::Range(b * rows_ / bands_, (b + 1) * rows_ / bands_);
    return cv::Range(b * band_rows_, std::min(rows_, (b + 1) * band_rows_));
  }

 private:
  int rows_ = 0, band_rows_ = 1, bands_ = 0;
  bool spread_ = false;
};

// Calls band_function(band) for bands of about `band_rows` rows covering
// `rows` (laid out for OpenCV's thread count), in parallel. A band's rows
// read only image rows when the filter reaches at most `halo` rows, so the
// band and the whole image agree there (up to the order of a running sum).
template <typename BandFunction>
void ForEachRowBand(int rows, int band_rows, int halo, const BandFunction& band_function) {
  const RowBandLayout layout(rows, band_rows, cv::getNumThreads());
  cv::parallel_for_(cv::Range(0, layout.bands()), [&](const cv::Range& range) {
    for (int b = range.start; b < range.end; ++b) {
      const cv::Range own = layout.Rows(b);
      RowBand band;
      band.first = own.start;
      band.last = own.end;
      band.from = std::max(0, band.first - halo);
      band.to = std::min(rows, band.last + halo);
      band_function(band);
    }
  });
}

}  // namespace dfsm
