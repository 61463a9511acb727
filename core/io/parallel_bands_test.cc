#include "core/io/parallel_bands.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace dfsm
