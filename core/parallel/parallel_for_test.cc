#include "core/parallel/parallel_for.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <mutex>
#include <vector>

namespace dfsm {
namespace {

TEST(ForEachRowBand, CoversEveryRowOnceWithItsHaloClampedIntoTheImage) {
  for (const int rows : {1, 7, 64, 65, 1080}) {
    std::vector<int> owned(rows, 0);
    std::mutex lock;
    ForEachRowBand(rows, 64, 3, [&](const RowBand& band) {
      EXPECT_LE(band.from, band.first);
      EXPECT_EQ(band.from, std::max(0, band.first - 3));
      EXPECT_EQ(band.to, std::min(rows, band.last + 3));
      EXPECT_LE(band.last - band.first, 64);
      EXPECT_EQ(band.Own().start, band.first - band.from);
      EXPECT_EQ(band.Own().size(), band.last - band.first);
      const std::lock_guard<std::mutex> guard(lock);
      for (int y = band.first; y < band.last; ++y) ++owned[y];
    });
    for (int y = 0; y < rows; ++y) EXPECT_EQ(owned[y], 1) << "row " << y << " of " << rows;
  }
}

// Band b's rows under the layout, checked to tile [0, rows) in order.
std::vector<int> BandHeights(const RowBandLayout& layout, int rows) {
  std::vector<int> heights;
  int next = 0;
  for (int b = 0; b < layout.bands(); ++b) {
    const cv::Range own = layout.Rows(b);
    EXPECT_EQ(own.start, next) << "band " << b;
    EXPECT_GT(own.size(), 0) << "band " << b;
    heights.push_back(own.size());
    next = own.end;
  }
  EXPECT_EQ(next, rows);
  return heights;
}

TEST(RowBandLayout, AsManyBandsForEveryThreadWhereTheyKeepTheirMinimumRows) {
  for (const int rows : {1, 7, 40, 64, 65, 200, 480, 1080}) {
    for (const int band_rows : {16, 64, 128}) {
      for (const int threads : {1, 2, 3, 8}) {
        const RowBandLayout layout(rows, band_rows, threads);
        const std::vector<int> heights = BandHeights(layout, rows);
        const int plain = (rows + band_rows - 1) / band_rows;
        for (const int h : heights) EXPECT_LE(h, band_rows);
        if (layout.bands() != plain) {
          // Spread: a multiple of the threads, rows within one of each other.
          EXPECT_EQ(layout.bands() % threads, 0);
          const auto [low, high] = std::minmax_element(heights.begin(), heights.end());
          EXPECT_GE(*low, RowBandLayout::kMinSpreadRows);
          EXPECT_LE(*high - *low, 1);
        }
      }
    }
  }
  // The cases the comments name: 1080p sweep bands on two cores, and the
  // filters' 64-row bands, which are spread where 17 would leave one alone.
  EXPECT_EQ(BandHeights(RowBandLayout(1080, 128, 2), 1080), std::vector<int>(10, 108));
  EXPECT_EQ(BandHeights(RowBandLayout(1080, 64, 2), 1080), std::vector<int>(18, 60));
  EXPECT_EQ(RowBandLayout(480, 64, 2).bands(), 8);  // already a multiple: 7 x 64 + 32
  EXPECT_EQ(RowBandLayout(480, 64, 2).Rows(7), cv::Range(448, 480));
  EXPECT_EQ(RowBandLayout(40, 16, 2).bands(), 3);  // 4 bands would keep 10 rows
  EXPECT_EQ(RowBandLayout(0, 64, 2).bands(), 0);
}

}  // namespace
}  // namespace dfsm
