// A series kept for a run of any length: all of it while it is short, an
// evenly spread sample in bounded memory once it is long.
#include <gtest/gtest.h>

#include <algorithm>

#include "base/decimated_series.h"

namespace holofuse {
namespace {

TEST(DecimatedSeries, AShortRunKeepsEveryValue) {
  DecimatedSeries<int> series(8);
  for (int v = 0; v < 7; ++v) series.add(v);
  EXPECT_EQ(series.kept(), (std::vector<int>{0, 1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(series.count(), 7u);
  EXPECT_EQ(series.stride(), 1u);
}

// At capacity one of each two neighbours goes and the stride doubles: what
// is kept is always one value of each block of stride values since the
// first, never more than the capacity, and the storage never moves after
// the first value.
TEST(DecimatedSeries, ALongRunKeepsAnEvenSpreadInBoundedMemory) {
  DecimatedSeries<uint64_t> series(16);
  series.add(0);
  const uint64_t* storage = series.kept().data();
  for (uint64_t v = 1; v < 100000; ++v) {
    series.add(v);
    ASSERT_LT(series.kept().size(), 16u) << "after value " << v;
  }
  EXPECT_EQ(series.kept().data(), storage);
  EXPECT_EQ(series.count(), 100000u);
  const uint64_t stride = series.stride();
  EXPECT_GE(stride * 16, 100000u / 2) << "a sample spread over the whole run";
  for (size_t i = 0; i < series.kept().size(); ++i) {
    EXPECT_GE(series.kept()[i], i * stride);
    EXPECT_LT(series.kept()[i], (i + 1) * stride);
  }
}

// A series with a period that a fixed stride would see in one phase only
// (every other frame slow): the kept values hold both, in their shares.
TEST(DecimatedSeries, APeriodicSeriesIsSeenInEveryPhase) {
  DecimatedSeries<int> series(64);
  for (int v = 0; v < 100000; ++v) series.add(v % 2 == 0 ? 10 : 50);
  const std::vector<int>& kept = series.kept();
  const auto slow = std::count(kept.begin(), kept.end(), 50);
  EXPECT_GT(slow, static_cast<long>(kept.size()) / 4);
  EXPECT_LT(slow, static_cast<long>(kept.size()) * 3 / 4);
}

TEST(DecimatedSeries, AnOddOrTinyCapacityStillHalvesCleanly) {
  DecimatedSeries<int> series(3);  // taken as 4
  for (int v = 0; v < 12; ++v) series.add(v);
  EXPECT_EQ(series.stride(), 4u);
  ASSERT_EQ(series.kept().size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_GE(series.kept()[i], 4 * i);
    EXPECT_LT(series.kept()[i], 4 * i + 4);
  }
}

}  // namespace
}  // namespace holofuse
