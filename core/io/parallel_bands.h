// Bands of rows on OpenCV's pool, for the filters OpenCV runs on one core:
// each band is filtered from its rows and a halo of rows on each side, and
// keeps its own rows. Over a whole 1080p frame such a filter also allocates
// its full-size temporaries afresh (fresh pages are dear); a band's are small.
#pragma once

#include <algorithm>
#include <opencv2/core/utility.hpp>

namespace dfsm {

// Rows [first, last) are the band's own; [from, to) adds up to `halo` rows
// on each side, clamped into the image.
struct RowBand {
  int first = 0, last = 0, from = 0, to = 0;
  // The band's own rows within the rows [from, to) it was filtered from.
  cv::Range Own() const { return cv::Range(first - from, last - from); }
};

// Calls band_function(band) for bands of `band_rows` rows covering `rows`,
// in parallel. A band's rows read only image rows when the filter reaches
// at most `halo` rows, so the band and the whole image agree there (up to
// the order of a running sum).
template <typename BandFunction>
void ForEachRowBand(int rows, int band_rows, int halo, const BandFunction& band_function) {
  const int bands = (rows + band_rows - 1) / band_rows;
  cv::parallel_for_(cv::Range(0, bands), [&](const cv::Range& range) {
    for (int b = range.start; b < range.end; ++b) {
      RowBand band;
      band.first = b * band_rows;
      band.last = std::min(rows, band.first + band_rows);
      band.from = std::max(0, band.first - halo);
      band.to = std::min(rows, band.last + halo);
      band_function(band);
    }
  });
}

}  // namespace dfsm
