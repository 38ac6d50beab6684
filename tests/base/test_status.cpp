// Status and StatusOr, the bottom layer: an error travels as a value, and
// asking an error for its value is a broken contract that stops loudly.
#include <gtest/gtest.h>

#include <string>

#include "base/status.h"

namespace holofuse {
namespace {

StatusOr<int> parsedDigit(char c) {
  if (c < '0' || c > '9')
    return Status(StatusCode::kMalformed, std::string("'") + c + "' is not a digit");
  return c - '0';
}

StatusOr<int> sumOfDigits(const std::string& text) {
  int sum = 0;
  for (char c : text) {
    HOLOFUSE_ASSIGN_OR_RETURN(const int digit, parsedDigit(c));
    sum += digit;
  }
  return sum;
}

TEST(Status, AssignOrReturnPassesTheFirstErrorOnAndTheValuesThrough) {
  const StatusOr<int> sum = sumOfDigits("1234");
  ASSERT_TRUE(sum.isOk());
  EXPECT_EQ(*sum, 10);
  const StatusOr<int> bad = sumOfDigits("12x4y");
  ASSERT_FALSE(bad.isOk());
  EXPECT_EQ(bad.status().code(), StatusCode::kMalformed);
  EXPECT_EQ(bad.status().message(), "'x' is not a digit");
  EXPECT_EQ(bad.status().toString(), "malformed: 'x' is not a digit");
}

TEST(StatusDeathTest, TheValueOfAnErrorStopsTheProcessWithTheError) {
  const StatusOr<int> bad = parsedDigit('q');
  EXPECT_DEATH((void)bad.value(), "value\\(\\) of an error: malformed: 'q' is not a digit");
}

}  // namespace
}  // namespace holofuse
