// Eta: the time left of a long run, as a person reads it.
#include <gtest/gtest.h>

#include "base/eta.h"

namespace holofuse {
namespace {

TEST(Eta, TheTimeLeftReadsInTheLargestUnitsThatMatter) {
  EXPECT_EQ(Eta::text(0.5, 3), "ETA 2 s");  // 1.5 s rounds to 2
  EXPECT_EQ(Eta::text(30.0, 5), "ETA 2 min 30 s");
  EXPECT_EQ(Eta::text(1234.0, 3), "ETA 1 h 1 min");
  EXPECT_EQ(Eta::text(10.0, 0), "ETA 0 s");
}

TEST(Eta, NoEstimateBeforeTheFirstStep) {
  Eta eta;
  EXPECT_EQ(eta.text(10), "");
  eta.stepDone();
  EXPECT_EQ(eta.text(10).rfind("ETA ", 0), 0u) << eta.text(10);
}

TEST(Eta, ACountReadsAgainstItsTotalWithTheTimeLeft) {
  EXPECT_EQ(Eta::countOf(12, 40, 4.0), "12/40 (ETA 7 s)");  // 28 frames at 4 a second
  EXPECT_EQ(Eta::countOf(40, 40, 4.0), "40/40");
  EXPECT_EQ(Eta::countOf(3, 40, 0.0), "3/40") << "no pace yet";
  EXPECT_EQ(Eta::countOf(3, 0, 4.0), "3") << "no total";
}

// Work counted in shares of steps has no estimate before any share is done.
TEST(Eta, SharesOfStepsGiveNoEstimateBeforeAnyIsDone) {
  const Eta eta;
  EXPECT_EQ(eta.textOfShares(0.0, 2.0), "");
  EXPECT_EQ(eta.textOfShares(0.5, 0.0), "ETA 0 s");
}

}  // namespace
}  // namespace holofuse
