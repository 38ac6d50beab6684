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

}  // namespace
}  // namespace holofuse
